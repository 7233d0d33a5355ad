"""Bad input reaches the user as one line naming the file or argument, field and reason."""

import numpy as np
import pytest

import armlab
from armlab.cli import main
from armlab.control.adaptive import SlotineLi1DoF
from armlab.errors import ArmlabError
from armlab.references.joint import Sinusoid
from armlab.simulation import SimulationError
from armlab.simulation.results import ResultFileError


def _one_line_error(capsys):
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err
    return err


def test_robot_file_that_is_not_utf8(tmp_path, capsys):
    path = tmp_path / "enc.toml"
    path.write_bytes(b"\xff\xfe")
    assert main(["robots", str(path)]) == 2
    assert _one_line_error(capsys).endswith("enc.toml: file: is not UTF-8 text")


def test_scenario_file_that_is_not_utf8(tmp_path, capsys):
    path = tmp_path / "enc.toml"
    path.write_bytes(b"\xff\xfe")
    assert main(["run", str(path)]) == 2
    assert _one_line_error(capsys).endswith("enc.toml: file: is not UTF-8 text")


def test_run_rejects_an_output_path_that_is_a_file_before_simulating(tmp_path, capsys):
    target = tmp_path / "afile"
    target.write_text("")
    assert main(["run", "a6_pd_online", "--t-final", "0.01", "--out", str(target)]) == 2
    err = _one_line_error(capsys)
    assert "--out: exists and is not a directory" in err
    assert "running" not in capsys.readouterr().err


def test_non_finite_duration_is_named(capsys):
    assert main(["run", "a6_pd_online", "--t-final", "nan"]) == 2
    assert "--t-final: must be a positive finite time, got nan" in _one_line_error(capsys)


def test_with_link_mass_rejects_negative_mass_and_unknown_links():
    prp = armlab.load_robot("prp")
    with pytest.raises(ValueError, match="mass: must be a finite non-negative mass"):
        prp.with_link_mass("link4", -0.2)
    with pytest.raises(ValueError, match="link: 'linkX' is not a link of 'prp'"):
        prp.with_link_mass("linkX", 0.2)
    assert prp.with_link_mass("link4", 0.16).links[2].inertial.mass == 0.16


def test_simulate_names_the_bad_argument():
    link1 = armlab.load_robot("link1")
    controller = SlotineLi1DoF(model=link1, reference=Sinusoid(
        center=[0.0], amplitude=[0.5], omega=[1.0]), kd=1.0, lam=1.0, gamma=[1.0, 1.0, 1.0])
    with pytest.raises(SimulationError, match="^qd0: must be finite"):
        armlab.simulate(link1, controller, q0=[0.0], qd0=[np.inf], t_final=0.01, dt=0.001)
    with pytest.raises(SimulationError, match="^log_every: must be a positive integer"):
        armlab.simulate(link1, controller, q0=[0.0], t_final=0.01, dt=0.001, log_every=2.5)
    with pytest.raises(SimulationError, match="^rtol: must be a positive tolerance"):
        armlab.simulate(link1, controller, q0=[0.0], t_final=0.01, dt=0.001, method="adaptive", rtol=-1)


def test_adaptation_gain_must_be_positive_definite():
    link1 = armlab.load_robot("link1")
    reference = Sinusoid(center=[0.0], amplitude=[0.5], omega=[1.0])
    with pytest.raises(ArmlabError, match="gamma: a gain must be positive definite"):
        SlotineLi1DoF(model=link1, reference=reference, kd=1.0, lam=1.0, gamma=[1.0, 0.0, 1.0])
    with pytest.raises(ArmlabError, match="kd: must be one positive number"):
        SlotineLi1DoF(model=link1, reference=reference, kd=[1.0, 2.0], lam=1.0, gamma=[1.0, 1.0, 1.0])


def test_save_to_an_unwritable_place_leaves_nothing(tmp_path):
    link1 = armlab.load_robot("link1")
    controller = SlotineLi1DoF(model=link1, reference=Sinusoid(
        center=[0.0], amplitude=[0.5], omega=[1.0]), kd=1.0, lam=1.0, gamma=[1.0, 1.0, 1.0])
    result = armlab.simulate(link1, controller, q0=[0.0], t_final=0.01, dt=0.001)
    with pytest.raises(ResultFileError, match="cannot be written"):
        result.save(tmp_path / "missing-folder" / "run.csv")
    result.save(tmp_path / "run.csv")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.csv"]
