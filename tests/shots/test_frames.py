"""Frame ranges and output names (renderer/host/shots/frames.py), and the split of a shot into tasks."""
import numpy as np
import pytest

from rtc.renderer.host.shots.frames import ShotError, check_pattern, output_name, parse_frames, parse_time
from rtc.renderer.host.shots.plan import FrameAssembly, plan, split_count


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
        a.add(s0, samples[s0:s1])
    assert a.complete
    assert np.array_equal(a.film.sum, sequential)
    assert np.array_equal(a.image(), (sequential / 7).astype(np.float32))
    chunked = samples[:4].sum(0) + samples[4:].sum(0)    # what adding partial sums would give
    assert not np.array_equal(chunked, sequential)       # (so the order above is what is tested)
