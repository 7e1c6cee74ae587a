"""Frame ranges and output names (renderer/host/shots/frames.py), and the split of a shot into tasks."""
import numpy as np
import pytest

from rtc.renderer.host.shots.frames import ShotError, check_pattern, output_name, parse_frames, parse_time
from rtc.renderer.host.shots.plan import (MAX_RESULT_BYTES, MIN_TILE_PIXELS, FrameAssembly, Split, Task, grid, plan,
                                         split_count, split_for)
from rtc.renderer.host.render import check_window


def test_frame_ranges_include_both_ends_and_step():
    assert parse_frames('1:24') == list(range(1, 25))
    assert parse_frames('0:100:10') == [0, 10, 20, 30, 40, 50, 60, 70, 80, 90, 100]
    assert parse_frames('5:5') == [5]
    assert parse_frames('-2:2:2') == [-2, 0, 2]
    assert parse_frames('1:10:4') == [1, 5, 9]


@pytest.mark.parametrize('spec, words', [('1', 'A:B'), ('1:2:3:4', 'A:B'), ('a:3', "'a'"), ('1:x', "'x'"),
                                         ('5:1', 'before start'), ('1:9:0', 'at least 1'), ('1.5:3', "'1.5'"),
                                         ('0:99999999', 'more than')])
def test_bad_frame_ranges_say_what_is_wrong(spec, words):
    with pytest.raises(ShotError, match='--frames') as e:
        parse_frames(spec)
    assert words in str(e.value)


def test_single_time_codes():
    assert parse_time('12') == 12 and isinstance(parse_time('12'), int)
    assert parse_time('12.5') == 12.5
    for bad in ('nan', 'inf', 'x'):
        with pytest.raises(ShotError, match='--frame'):
            parse_time(bad)


def test_output_names():
    assert output_name('out/shot.####.exr', 7) == 'out/shot.0007.exr'
    assert output_name('out/shot.%04d.exr', 7) == 'out/shot.0007.exr'
    assert output_name('out/shot.%d.png', 123) == 'out/shot.123.png'
    assert output_name('s.##.exr', 1234) == 's.1234.exr'          # never truncated
    assert output_name('s.####.exr', -3) == 's.-003.exr'
    assert output_name('still.exr', 5) == 'still.exr'
    with pytest.raises(ShotError, match='whole frame'):
        output_name('s.####.exr', 2.5)


def test_patterns_fit_the_frame_count():
    check_pattern('s.####.exr', 10)
    check_pattern('still.exr', 1)
    with pytest.raises(ShotError, match='10 frames need a frame number'):
        check_pattern('still.exr', 10)
    with pytest.raises(ShotError, match='more than one'):
        check_pattern('s.####.%04d.exr', 2)


def test_split_keeps_whole_frames_when_they_feed_every_worker():
    assert split_count(24, 2, 320, 240, 16) == 1
    assert split_count(1, 1, 320, 240, 16) == 1
    assert split_count(1, 2, 32, 24, 16) == 4                        # about two tasks per worker
    assert split_count(1, 8, 32, 24, 4) == 4                         # never more ranges than samples
    assert split_count(1, 2, 4096, 4096, 64) == 1                    # too many bytes of single samples


def test_plan_covers_every_sample_once():
    tasks = plan([1, 2], 10, 3)
    assert [(t.frame, t.s0, t.s1) for t in tasks] == [(1, 0, 3), (1, 3, 7), (1, 7, 10), (2, 0, 3), (2, 3, 7),
                                                      (2, 7, 10)]
    assert len({t.key for t in tasks}) == 6
    assert [(t.s0, t.s1, t.whole) for t in plan([4], 3, 1)] == [(0, 3, True)]


def test_assembly_adds_single_samples_in_order_whatever_the_arrival_order():
    rng = np.random.default_rng(5)
    samples = rng.normal(size=(7, 2, 3, 3)) * 10.0 ** rng.integers(-8, 8, size=(7, 2, 3, 3))
    sequential = np.zeros((2, 3, 3))
    for s in samples:                                    # what the kernel does, sample by sample
        sequential += s
    a = FrameAssembly(3, 2, 7)
    for s0, s1 in ((4, 7), (0, 2), (2, 4)):
        assert not a.complete
        a.add(Task(1, s0, s1, False), {'samples': samples[s0:s1]})
    assert a.complete
    assert a.image().tobytes() == (sequential / 7).astype(np.float32).tobytes()
    chunked = samples[:4].sum(0) + samples[4:].sum(0)    # what adding partial sums would give
    assert not np.array_equal(chunked, sequential)       # (so the order above is what is tested)


def test_tiles_lie_on_the_kernel_grid_and_cover_the_image_once():
    for w, h, n in ((320, 240, 4), (1920, 1080, 9), (100, 37, 5), (33, 9, 50), (8, 8, 3), (4000, 3000, 1)):
        boxes = grid(w, h, n)
        assert len(boxes) >= min(n, -(-w // 8) * -(-h // 8)), (w, h, n)
        assert all(check_window(b, w, h) == b for b in boxes), (w, h, n)      # no RenderError
        cover = np.zeros((h, w), int)
        for x0, y0, x1, y1 in boxes:
            cover[y0:y1, x0:x1] += 1
        assert (cover == 1).all(), (w, h, n)
    sizes = {(x1 - x0, y1 - y0) for x0, y0, x1, y1 in grid(1920, 1080, 8)}
    assert max(max(s) / min(s) for s in sizes) < 2.5                 # near-square, not strips


def test_split_prefers_tiles_and_adds_sample_ranges_when_tiles_are_too_few():
    assert split_for(24, 2, 1920, 1080, 16) == Split((None,), 1)          # frames feed the workers
    assert split_for(1, 1, 1920, 1080, 16, cluster=False) == Split((None,), 1)
    s = split_for(1, 2, 1920, 1080, 16)                                   # one large frame, 2 workers
    assert s.ranges == 1 and len(s.tiles) == 4                            # tiles only: no extra bytes
    s = split_for(1, 2, 1280, 720, 16)                                    # 4 wanted, 56 tiles of 128x128 fit
    assert s.ranges == 1 and len(s.tiles) == 4
    s = split_for(1, 16, 1280, 720, 16)                                   # 32 wanted
    assert s.ranges == 1 and len(s.tiles) >= 32
    assert min((x1 - x0) * (y1 - y0) for x0, y0, x1, y1 in s.tiles) >= MIN_TILE_PIXELS * 0.75
    s = split_for(1, 8, 320, 240, 16)                                     # 16 wanted, 4 tiles: x 4 sample ranges
    assert len(s.tiles) == 320 * 240 // MIN_TILE_PIXELS == 4 and s.ranges == 4
    assert split_for(1, 2, 32, 24, 16) == Split((None,), 4)               # too small to tile: sample ranges
    assert split_for(1, 2, 4096, 4096, 64).ranges == 1                    # too many bytes of single samples


def test_a_frame_larger_than_a_result_is_tiled_on_any_cluster():
    w, h = 8192, 4096                                                     # 384 MB of float32 pixels
    s = split_for(100, 2, w, h, 4)
    assert len(s.tiles) >= w * h * 12 / MAX_RESULT_BYTES and s.ranges == 1
    assert max((x1 - x0) * (y1 - y0) * 12 for x0, y0, x1, y1 in s.tiles) <= MAX_RESULT_BYTES
    assert split_for(100, 2, w, h, 4, cluster=False) == Split((None,), 1)   # in this process: whole


def test_plan_of_tiles_and_sample_ranges_covers_every_pixel_sample_once():
    boxes = grid(64, 48, 4)
    tasks = plan([7], 5, Split(boxes, 2))
    assert len(tasks) == 8 and len({t.key for t in tasks}) == 8
    count = np.zeros((48, 64), int)
    for t in tasks:
        x0, y0, x1, y1 = t.box
        count[y0:y1, x0:x1] += t.s1 - t.s0
    assert (count == 5).all()
    assert all(t.whole for t in plan([7], 5, Split(boxes, 1)))


def test_assembly_of_tiles_and_their_sample_ranges():
    rng = np.random.default_rng(2)
    w, h, spp = 24, 16, 3
    samples = rng.random((spp, h, w, 3)) * 10.0 ** rng.integers(-6, 6, size=(spp, h, w, 3))
    total = np.zeros((h, w, 3))
    for s in samples:
        total += s
    want = (total / spp).astype(np.float32)
    boxes = grid(w, h, 4)
    a = FrameAssembly(w, h, spp, boxes)
    pieces = [(t, {'samples': samples[t.s0:t.s1, t.box[1]:t.box[3], t.box[0]:t.box[2]]})
              for t in plan([1], spp, Split(boxes[1:], 2))]
    x0, y0, x1, y1 = boxes[0]
    pieces.append((Task(1, 0, spp, True, boxes[0]), {'image': want[y0:y1, x0:x1]}))
    for t, out in reversed(pieces):
        assert not a.complete
        a.add(t, out)
    assert a.complete and a.image().tobytes() == want.tobytes()
    with pytest.raises(ValueError, match='tile'):
        FrameAssembly(w, h, spp, boxes).add(Task(1, 0, spp, True, boxes[0]), {'image': want})
