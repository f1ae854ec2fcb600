"""The Simulation's numpy arrays are the state `lsdem run` writes: after the
same steps, the particle and contact frames of a run hold the same values."""

import pathlib

import numpy as np
import pytest

import lsdem
from conftest import SHORT_STEPS


@pytest.fixture(scope="module")
def same_step(tmp_path_factory, scene_path):
    """The last frames of a run of SHORT_STEPS, and a Simulation stepped as far."""
    out = tmp_path_factory.mktemp("run")
    lsdem.run(scene_path, out=out, steps=SHORT_STEPS, threads=1)
    series = lsdem.read_pvd(out / "particles.pvd")
    contacts = lsdem.read_pvd(out / "contacts.pvd")
    sim = lsdem.Simulation(scene_path, threads=1)
    assert sim.step(SHORT_STEPS) == SHORT_STEPS
    return sim, series[-1], lsdem.read_vtp(out / series[-1][1]), lsdem.read_vtp(out / contacts[-1][1]), out


def test_particle_arrays_match_the_last_particle_frame(same_step):
    sim, (time, _), frame, _, _ = same_step
    assert time == sim.time
    assert len(sim.breakage_log()) >= 2  # fragments are in the comparison
    n = len(sim)
    points, data = frame["points"], frame["point_data"]
    assert points.shape == (n, 3)
    np.testing.assert_array_equal(data["id"], sim.ids)
    np.testing.assert_array_equal(data["generation"], sim.generations)
    parents = np.where(sim.parent_ids == np.iinfo(np.uint64).max, -1, sim.parent_ids.astype(np.int64))
    np.testing.assert_array_equal(data["parent_id"], parents)
    assert sim.generations.max() >= 1
    # Values to round-off (the frames store the doubles themselves).
    np.testing.assert_allclose(points[:, :2], sim.positions, rtol=1e-14, atol=0)
    np.testing.assert_array_equal(points[:, 2], 0.0)
    np.testing.assert_allclose(data["velocity"][:, :2], sim.velocities, rtol=1e-14, atol=0)
    np.testing.assert_allclose(data["angular_velocity"][:, 2], sim.angular_velocities, rtol=1e-14, atol=0)
    np.testing.assert_allclose(data["mass"], sim.masses, rtol=1e-14, atol=0)
    np.testing.assert_allclose(data["equivalent_diameter"], sim.equivalent_diameters(), rtol=1e-14, atol=0)
    np.testing.assert_allclose(data["radius"], sim.bounding_radii(), rtol=1e-14, atol=0)
    np.testing.assert_allclose(data["stress"], sim.stresses(), rtol=1e-12, atol=0)
    strengths = np.where(np.isfinite(sim.strengths), sim.strengths, -1.0)  # -1: made unbreakable
    np.testing.assert_allclose(data["strength"], strengths, rtol=1e-14, atol=0)
    # 2D orientation: the quaternion (cos a/2, 0, 0, sin a/2) of the angle a.
    a = sim.orientations
    q = np.stack([np.cos(a / 2), np.zeros(n), np.zeros(n), np.sin(a / 2)], axis=1)
    sign = np.sign(np.sum(q * data["orientation"], axis=1))[:, None]  # q and -q are one rotation
    np.testing.assert_allclose(sign * data["orientation"], q, rtol=0, atol=1e-14)
    # The rotation matrices are those of the angles.
    r = sim.rotations()
    np.testing.assert_allclose(r[:, 0, 0], np.cos(a), rtol=0, atol=1e-15)
    np.testing.assert_allclose(r[:, 1, 0], np.sin(a), rtol=0, atol=1e-15)
    np.testing.assert_allclose(data["axis_x"][:, :2], r[:, :, 0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(data["axis_y"][:, :2], r[:, :, 1], rtol=0, atol=1e-15)


def test_written_particle_frame_equals_the_runs(same_step, tmp_path):
    sim, _, frame, _, _ = same_step
    sim.write_particles_vtp(tmp_path / "p.vtp")
    mine = lsdem.read_vtp(tmp_path / "p.vtp")
    np.testing.assert_array_equal(mine["points"], frame["points"])
    assert mine["point_data"].keys() == frame["point_data"].keys()
    for name, values in frame["point_data"].items():
        np.testing.assert_array_equal(mine["point_data"][name], values, err_msg=name)


def test_contacts_match_the_last_contact_frame(same_step):
    sim, _, _, chains, _ = same_step
    pairs = sim.contacts()["pairs"]
    touching = (pairs["kind"] == 0) & (pairs["node_count"] > 0)
    assert touching.sum() > 0
    cells = chains["cell_data"]
    assert len(cells["id_a"]) == touching.sum()
    np.testing.assert_array_equal(cells["id_a"], pairs["id_a"][touching])
    np.testing.assert_array_equal(cells["id_b"], pairs["id_b"][touching])
    np.testing.assert_array_equal(cells["node_contacts"], pairs["node_count"][touching])
    np.testing.assert_allclose(cells["force"][:, :2], pairs["force"][touching], rtol=1e-14, atol=0)
    np.testing.assert_allclose(cells["force_magnitude"], np.linalg.norm(pairs["force"][touching], axis=1),
                               rtol=1e-14, atol=0)


def test_breakage_log_written_from_python_equals_the_runs(same_step, tmp_path):
    sim, _, _, _, out = same_step
    sim.write_breakage_log(tmp_path / "log.csv")
    assert (tmp_path / "log.csv").read_bytes() == (out / "breakage_log.csv").read_bytes()
    log = sim.breakage_log()
    rows = (out / "breakage_log.csv").read_text().splitlines()[1:]
    assert len(rows) == len(log)
    ids = set(int(i) for i in sim.ids)
    for event in log:
        assert event["parent"] not in ids
        assert event["strength"] > 0 and event["criterion_value"] >= event["strength"]
        assert abs(np.linalg.norm(event["plane_normal"]) - 1.0) < 1e-12
        assert event["fragment_mass"] == pytest.approx(event["parent_mass"], rel=1e-12)


def test_summary_of_the_world_matches_the_runs(same_step):
    import json
    sim, _, _, _, out = same_step
    run = json.loads((out / "summary.json").read_text())
    mine = sim.summary()
    for key in ("steps", "simulated_time", "dt", "critical_dt", "particles", "contacts", "node_contacts",
                "energy", "mass", "time_step"):
        assert mine[key] == run[key], key
