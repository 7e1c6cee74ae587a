import io

from rtc.renderer.host.progress import Progress, summary_line


class FakeTTY(io.StringIO):
    def isatty(self):
        return True


def test_summary_line_format():
    assert summary_line(3.21, 64, 19_680_000, 640, 480) == \
        'rendered 640x480 at 64 spp in 3.21 s: 19.7 M rays, 6.13 Mrays/s'
    assert summary_line(0.5, 1, 41_200) == 'rendered at 1 spp in 0.50 s: 0.0412 M rays, 0.0824 Mrays/s'
    assert summary_line(10.0, 256, 1_234_000_000, 2, 2).endswith('1234 M rays, 123 Mrays/s')
    assert 'inf Mrays/s' in summary_line(0.0, 1, 10)


def test_silent_when_not_a_tty_or_quiet():
    s = io.StringIO()
    with Progress(8, 8, 16, passes=4, stream=s) as p:
        assert not p.enabled
        for _ in range(4):
            p.update(4, 1000)
    assert s.getvalue() == ''
    assert p.spp == 16 and p.rays == 4000 and p.passes == 4
    t = FakeTTY()
    with Progress(8, 8, 16, stream=t, quiet=True) as q:
        q.update(16, 10)
    assert t.getvalue() == ''


def test_bar_on_tty():
    t = FakeTTY()
    with Progress(8, 8, 16, passes=2, stream=t, mininterval=0) as p:
        assert p.enabled
        p.update(8, 10**6)
        p.update(8, 10**6)
    out = t.getvalue()
    assert '16/16' in out and 'spp' in out and 'Mrays/s' in out and 'pass 2/2' in out
    line = p.summary(seconds=2.0)
    assert line == 'rendered 8x8 at 16 spp in 2.00 s: 2.00 M rays, 1.00 Mrays/s'
