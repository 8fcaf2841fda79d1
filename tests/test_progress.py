"""Plain-line progress (stderr no terminal: logs, CI, the demo's workers) estimates the time left from the rate
so far, so that a run far longer than the docs' typical one (an in-domain but extreme material's MCML: 24 min a
channel) says so in its first lines."""

import pytest

import ssskit.progress as progress


@pytest.fixture
def clock(monkeypatch):
    now = [0.0]
    monkeypatch.setattr(progress.time, "perf_counter", lambda: now[0])
    return now


def test_a_plain_line_estimates_the_time_left(clock, capsys):
    bar = progress._LineProgress(1000, "Skin1 R", "photons")
    clock[0] = 1.0
    bar.update(100)  # a tenth, but only 1 s in: the rate is not trusted yet
    assert capsys.readouterr().err.strip() == "Skin1 R: 100/1,000 photons (1 s)"
    clock[0] = 10.0
    bar.update(150)  # 250 in 10 s: 750 more at that rate take 30 s
    assert capsys.readouterr().err.strip() == "Skin1 R: 250/1,000 photons (10 s, about 30 s left)"
    clock[0] = 40.0
    bar.update(750)
    assert capsys.readouterr().err.strip() == "Skin1 R: 1,000/1,000 photons (40 s)"  # done: nothing left to estimate


def test_a_resumed_run_counts_its_rate_from_where_it_resumed(clock, capsys):
    bar = progress._LineProgress(10_000_000, "clear G", "photons", initial=5_000_000)
    clock[0] = 6.0
    bar.update(1_000_000)  # 1e6 in 6 s: 4e6 more take 24 s, not the 4 s the whole count would say
    assert "(6 s, about 24 s left)" in capsys.readouterr().err


@pytest.mark.parametrize("seconds, text", [(40.4, "40 s"), (89.0, "89 s"), (90.0, "2 min"), (24 * 60, "24 min"),
                                           (90 * 60, "1.5 h"), (10 * 3600, "10.0 h")])
def test_duration_text(seconds, text):
    assert progress.duration_text(seconds) == text
