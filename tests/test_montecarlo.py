"""Monte Carlo of model uncertainty: truncated normal and lognormal draws (against SciPy's own
distributions), the bundled A7 sweep over ±20 % link masses (each run's steady-state error
against the closed-loop equilibrium B̂ K_P q̃ = g − ĝ solved apart), its ECDF plot and the
report's table of its worst runs."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy import stats

import armlab
from armlab.errors import SweepFileError
from armlab.scenarios import load_scenario
from armlab.sweep import load_sweep, load_sweep_file, read_results, sweep
from armlab.sweep.spec import Axis, draw_value

pytest.importorskip("pyarrow", reason="sweeps need pyarrow (the 'sweep' extra)")

DRAWS = 20000
# Kolmogorov–Smirnov distance of 20 000 draws: 1.95/√n ≈ 0.0138 is the 0.1 % critical value; the
# draws are seeded, so each check is one fixed number, far below it when the sampler is right.
KS_LIMIT = 0.0138


def _draws(axis, seed=1):
    rng = np.random.default_rng(seed)
    return np.array([draw_value(rng, axis) for _ in range(DRAWS)])


@pytest.mark.parametrize("axis, reference", [
    (Axis("m", (), "normal", (1.0, 0.2), (0.8, 1.2)), stats.truncnorm(-1.0, 1.0, loc=1.0, scale=0.2)),
    (Axis("m", (), "normal", (0.0, 1.0), (0.5, np.inf)), stats.truncnorm(0.5, np.inf)),
    (Axis("m", (), "lognormal", (0.0, 0.5)), stats.lognorm(0.5)),
    (Axis("m", (), "lognormal", (np.log(0.2), 0.3), (0.1, 0.25)),
     stats.truncnorm((np.log(0.1) - np.log(0.2)) / 0.3, (np.log(0.25) - np.log(0.2)) / 0.3,
                     loc=np.log(0.2), scale=0.3)),
])
def test_truncated_and_lognormal_draws_follow_their_distributions(axis, reference):
    x = _draws(axis)
    if axis.kind == "lognormal" and axis.within is not None:
        x = np.log(x)                     # the reference is the truncated normal of ln x
    if axis.within is not None:
        low, high = axis.within
        assert np.all(x >= (np.log(low) if axis.kind == "lognormal" else low))
        assert np.all(x <= (np.log(high) if axis.kind == "lognormal" else high))
    assert stats.kstest(x, reference.cdf).statistic < KS_LIMIT


def test_an_untruncated_normal_draws_as_before():
    """Sweeps written before truncation existed draw the same numbers (numpy's normal)."""
    x = _draws(Axis("m", (), "normal", (1.0, 0.5)), seed=3)
    assert np.array_equal(x, np.random.default_rng(3).normal(1.0, 0.5, DRAWS))


def _write(tmp_path, draw):
    path = tmp_path / "s.toml"
    path.write_text(f'scenario = "a7_id_high_gain"\nruns = 2\n[random]\na = {{ {draw} }}\n', encoding="utf-8")
    return path


@pytest.mark.parametrize("draw, field, reason", [
    ("uniform = [0, 1], within = [0, 1]", "random.a.within", "only a normal or a lognormal"),
    ("normal = [0, 1], within = [1, 0]", "random.a.within", "low < high"),
    ("normal = [0, 1], within = [40, 41]", "random.a.within", "of the distribution's probability"),
    ("lognormal = [0, 1], within = [-1, 1]", "random.a.within", "must be ≥ 0"),
    ("lognormal = [0, 0]", "random.a.lognormal", "σ > 0"),
    ("lognormal = [700, 1]", "random.a.lognormal", "range of a float"),
    ("normal = [0, 1], wihtin = [0, 1]", "random.a", "expected one of"),
])
def test_bad_draws_are_one_line_naming_the_field(tmp_path, draw, field, reason):
    with pytest.raises(SweepFileError, match=reason) as caught:
        load_sweep_file(_write(tmp_path, draw))
    assert f"s.toml: {field}:" in str(caught.value) and "\n" not in str(caught.value)


@pytest.fixture(scope="module")
def link_masses(tmp_path_factory):
    """The bundled A7 Monte Carlo, its first 6 draws (the full 200 are `armlab sweep`'s)."""
    spec = dataclasses.replace(load_sweep("a7_link_masses_montecarlo"), draws=6, chunk_size=3)
    out = tmp_path_factory.mktemp("mc")
    sweep(spec, out, threads=1)
    return spec, out, read_results(out).to_pandas()


def test_link_mass_draws_stay_within_20_percent_and_runs_settle_on_theory(link_masses):
    """Each run's steady-state error is the rest equilibrium (H1) of its drawn model, solved by
    :func:`armlab.theory.computed_torque_equilibrium` from the robots alone."""
    from armlab.theory import computed_torque_equilibrium

    spec, _, frame = link_masses
    plant = armlab.load_robot("prp")
    q_final = np.array([0.15, np.pi / 6, 0.1])
    assert (frame["status"] == "ok").all() and len(frame) == 6
    for _, row in frame.iterrows():
        model = plant
        for link, mass in (("link2", 0.5), ("link3", 0.3), ("link4", 0.2)):
            delta = row[f"delta_{link}"]
            assert -0.2 <= delta <= 0.2
            assert row[f"controller.model_link_mass.{link}"] == pytest.approx(mass * (1 + delta), rel=1e-15)
            model = model.with_link_mass(link, mass * (1 + delta))
        scenario = load_scenario("a7_id_via_points")
        controller = dataclasses.replace(scenario.controller, model=model)
        expected = np.abs(computed_torque_equilibrium(plant, controller, q_final)).max()
        assert row["steady_state_error"] == pytest.approx(expected, rel=1e-4, abs=1e-9)
    assert frame["steady_state_error"].max() > 1e-3            # the mismatch does show


def test_montecarlo_plots_and_worst_runs(link_masses):
    from armlab.viz.sweeps import plot_sweep, sweep_section, worst_runs

    spec, out, frame = link_masses
    paths = plot_sweep(spec, out)
    assert [p.name.split("-", 2)[-1] for p in paths] == ["histogram.png", "ecdf.png", "scatter.png"]
    metric, rows = worst_runs(frame, ["delta_link4"], count=3)
    assert metric == "rms_error" and len(rows) == 3
    ranked = frame.sort_values("rms_error", ascending=False).head(3)
    assert [r[0] for r in rows] == ranked["run"].tolist()
    assert [r[1] for r in rows] == ranked["delta_link4"].tolist()
    page = sweep_section(out)
    assert "runs of largest rms error" in page and page.count("<tr>") >= 5 + 1
