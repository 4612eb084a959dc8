"""seed_bench's summary: the ratio of variance × CPU between scenes and
its interval over the seeds."""
import numpy as np
import pytest

from seed_bench import summarise, summary_lines


def test_ratio_is_of_the_means_and_its_interval_holds_it():
    rng = np.random.default_rng(1)
    seeds = 24
    # Heavy-tailed errors, as a render's relMSE over seeds is: the first
    # scene's are 9 times the second's in expectation, at the same CPU.
    noisy = rng.lognormal(0.0, 0.6, seeds) * 9.0
    quiet = rng.lognormal(0.0, 0.6, seeds)
    runs = {"path": [(e, 4.0) for e in noisy], "caustics": [(e, 4.0) for e in quiet]}
    s = summarise(runs)
    assert s["path"]["ratio"] == pytest.approx(1.0)
    expected = noisy.mean() / quiet.mean()
    assert s["caustics"]["ratio"] == pytest.approx(expected)
    assert s["caustics"]["low"] < expected < s["caustics"]["high"]
    # 24 lognormal draws of σ 0.6 leave the ratio uncertain by about ±20%
    # (each mean's relative error about 0.66/√24 ≈ 0.13): the interval
    # must show that, neither a point nor the whole line.
    assert 0.6 < s["caustics"]["low"] / expected < 0.95
    assert 1.05 < s["caustics"]["high"] / expected < 1.6
    stderr = quiet.std(ddof=1) / np.sqrt(seeds)
    assert s["caustics"]["stderr"] == pytest.approx(stderr)


def test_cpu_counts_in_the_ratio_and_lines_name_the_first():
    runs = {"a": [(2.0, 1.0), (2.0, 1.0)], "b": [(1.0, 4.0), (1.0, 4.0)]}
    s = summarise(runs)
    # 2 × 1 against 1 × 4: the first scene is twice as good.
    assert s["b"]["ratio"] == pytest.approx(0.5)
    assert s["b"]["low"] == pytest.approx(0.5) and s["b"]["high"] == pytest.approx(0.5)
    lines = summary_lines(runs)
    assert lines[0].startswith("a: mean relMSE 2.0000e+00")
    assert "a over this: 0.50 (90%: 0.50–0.50)" in lines[1]


def test_every_scene_needs_every_seed():
    with pytest.raises(ValueError):
        summarise({"a": [(1.0, 1.0), (1.0, 1.0)], "b": [(1.0, 1.0)]})
