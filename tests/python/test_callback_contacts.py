"""Per-step callbacks that read the contacts, scenes from dicts, particle arrays, errors."""

import pathlib
import tomllib

import numpy as np
import pytest

import lsdem


def scene_dict(path):
    with open(path, "rb") as f:
        return tomllib.load(f)


def test_contact_records_add_up_to_the_particle_forces_every_step(scene_path):
    # Without global damping, the force on a particle after a step is its
    # contact forces plus its weight: the pair records (a gets +force, b gets
    # -force; plane records act on a alone) must add up to it, each pair's
    # force must be the sum of its node contacts' forces, and each plane's
    # load the opposite of its records' forces.
    d = scene_dict(scene_path)
    del d["effects"]["global_damping"]
    g = np.array(d["effects"]["gravity"])
    sim = lsdem.Simulation(lsdem.Scene.from_dict(d), threads=1)
    platen = lsdem.Scene(scene_path).planes.index("platen")
    checked = {"steps": 0, "pairs": 0, "nodes": 0, "platen": 0}

    def check(s):
        c = s.contacts()
        pairs, nodes = c["pairs"], c["nodes"]
        n = len(s)
        expected = s.masses[:, None] * g
        np.add.at(expected, pairs["a"], pairs["force"])
        particle = pairs["kind"] == 0
        np.add.at(expected, pairs["b"][particle], -pairs["force"][particle])
        scale = np.abs(s.forces).max()
        np.testing.assert_allclose(s.forces, expected, rtol=0, atol=1e-12 * scale)
        assert expected.shape == (n, 2)

        # Each pair's force is the sum of its node contacts' forces.
        node_sum = np.zeros_like(pairs["force"])
        np.add.at(node_sum, nodes["pair"], nodes["force"])
        np.testing.assert_allclose(node_sum, pairs["force"], rtol=0, atol=1e-12 * max(scale, 1e-300))
        np.testing.assert_array_equal(np.bincount(nodes["pair"], minlength=len(pairs["a"])), pairs["node_count"])
        assert np.all(nodes["overlap"] > 0)
        np.testing.assert_allclose(np.linalg.norm(nodes["normal"], axis=1), 1.0, rtol=0, atol=1e-12)
        assert np.all(pairs["id_a"][particle] < pairs["id_b"][particle])  # a: the lower id

        # The platen's load is what its records push on the particles, reversed.
        on_platen = (pairs["kind"] == 1) & (pairs["b"] == platen)
        load = s.boundaries()["planes"][platen]["force"]
        np.testing.assert_allclose(load, -pairs["force"][on_platen].sum(axis=0), rtol=0,
                                   atol=1e-12 * max(scale, 1e-300))
        checked["steps"] += 1
        checked["pairs"] += int(particle.sum())
        checked["nodes"] += len(nodes["point"])
        checked["platen"] += int(on_platen.any())

    # Undamped, the first grains break after about 10,000 steps; step on
    # until fragments have been among the particles checked.
    sim.add_callback(check, every=7)
    while len(sim.breakage_log()) < 2 and sim.steps < 60_000:
        assert sim.step(2_000) == 2_000
    steps = sim.steps + 700  # and a while after the second breakage
    assert sim.step(700) == 700
    assert checked["steps"] == steps // 7
    assert checked["pairs"] > 0 and checked["nodes"] > 0
    assert checked["platen"] > 0
    assert len(sim.breakage_log()) >= 2  # fragments were among the particles checked


def test_a_scene_from_a_dict_runs_as_its_file(scene_path):
    from_file = lsdem.Simulation(scene_path, threads=1)
    from_dict = lsdem.Simulation(lsdem.Scene.from_dict(scene_dict(scene_path)), threads=1)
    from_file.step(500)
    from_dict.step(500)
    np.testing.assert_array_equal(from_dict.positions, from_file.positions)
    np.testing.assert_array_equal(from_dict.angular_velocities, from_file.angular_velocities)


def test_a_dict_scene_error_names_the_written_files_line(tmp_path, scene_path):
    d = scene_dict(scene_path)
    d["contact"]["friction"] = -0.2
    with pytest.raises(lsdem.InputError) as e:
        lsdem.Scene.from_dict(d, path=tmp_path / "s.toml")
    lines = (tmp_path / "s.toml").read_text().splitlines()
    assert e.value.key == "contact.friction"
    key, value = lines[e.value.line - 1].split("=")
    assert key.strip() == "friction" and float(value) == -0.2  # written with 17 digits, read back exactly
    assert str(e.value).startswith(f"{tmp_path / 's.toml'}:{e.value.line}: contact.friction: ")
    with pytest.raises(TypeError, match=r"effects\.gravity\[1\]: a object has no TOML form"):
        d["effects"]["gravity"] = [0.0, object()]
        lsdem.Scene.toml(d)


def test_temporary_scene_file_goes_with_the_scene(scene_path):
    scene = lsdem.Scene.from_dict(scene_dict(scene_path))
    path = pathlib.Path(scene.path)
    assert path.is_file() and scene.dimension == 2 and scene.duration == 0.08
    sim = lsdem.Simulation(scene)
    del scene
    assert not path.exists()
    assert sim.step(3) == 3  # the world does not need the file


def test_particle_arrays_are_copies_that_keep_their_values(scene_path):
    sim = lsdem.Simulation(scene_path, threads=1)
    assert len(sim) == 3
    pos = sim.positions
    assert pos.shape == (3, 2) and pos.dtype == np.float64 and pos.flags.owndata
    assert sim.ids.dtype == np.uint64 and sim.generations.dtype == np.int32
    np.testing.assert_array_equal(sim.ids, [0, 1, 2])
    np.testing.assert_array_equal(sim.parent_ids, [2**64 - 1] * 3)
    np.testing.assert_allclose(sim.positions, [[0.0, 0.00065], [0.00003, 0.00175], [-0.00002, 0.00285]],
                               rtol=0, atol=1e-12)
    before = pos.copy()
    pos[0, 0] = 1.0  # a copy: the world is not changed
    assert sim.positions[0, 0] == before[0, 0]
    pos[0, 0] = before[0, 0]
    sim.step(100)
    # An array read before keeps its values; read again, it has the world's.
    np.testing.assert_array_equal(pos, before)
    assert np.all(sim.positions[:, 1] < before[:, 1])  # the grains settle under gravity
    assert sim.masses.sum() == pytest.approx(sim.true_masses().sum(), rel=1e-15)
    assert sim.summary()["particles"] == 3
    # state(): copies that stay as they are.
    state = sim.state()
    assert state["positions"].flags.writeable and state["positions"].flags.owndata
    assert state["steps"] == 100 and state["time"] == sim.time
    kept = state["positions"].copy()
    sim.step(10)
    np.testing.assert_array_equal(state["positions"], kept)
    assert not np.array_equal(state["positions"], sim.positions)
    assert set(state) >= {"velocities", "angular_velocities", "orientations", "ids", "generations", "rotations"}


def test_callbacks_stop_raise_and_refuse_reentry(scene_path):
    sim = lsdem.Simulation(scene_path, threads=1)
    seen = []
    handle = sim.add_callback(lambda s: seen.append(s.steps) or s.steps < 30, every=10)
    assert sim.step(100) == 30
    assert seen == [10, 20, 30]
    sim.remove_callback(handle)
    assert sim.callbacks == 0

    def fail(s):
        raise ZeroDivisionError("from the callback")

    sim.add_callback(fail)
    with pytest.raises(ZeroDivisionError, match="from the callback"):
        sim.step(5)
    assert sim.steps == 31  # the step before the callback is done
    sim.remove_callback(2)
    sim.add_callback(lambda s: s.step(1))
    with pytest.raises(RuntimeError, match="already stepping"):
        sim.step(1)


def test_three_dimensional_state(tmp_path):
    # An ellipsoid dropping on a plane, 3D (positions as a numpy array): quaternions
    # scalar last, rotations.
    scene = lsdem.Scene.from_dict({
        "simulation": {"dimension": 3, "steps": 200, "dt": "auto"},
        "contact": {"kn": 1e5},
        "shapes": {"egg": {"kind": "ellipsoid", "semi_axes": [0.0012, 0.001, 0.0008], "cells_across": 10}},
        "particles": [{"shape": "egg", "density": 2650.0, "placement": "list",
                       "positions": np.array([[0.0, 0.0, 0.0015]]), "rotations_deg": [[30.0, 20.0, 10.0]]}],
        "planes": [{"name": "floor", "point": [0.0, 0.0, 0.0], "normal": [0.0, 0.0, 1.0]}],
        "effects": {"gravity": [0.0, 0.0, -9.81]},
    })
    sim = lsdem.Simulation(scene, threads=1)
    sim.step(200)
    assert sim.positions.shape == (1, 3) and sim.angular_velocities.shape == (1, 3)
    q = sim.orientations
    assert q.shape == (1, 4)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, rtol=0, atol=1e-12)
    x, y, z, w = q[0]
    r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    np.testing.assert_allclose(sim.rotations()[0], r, rtol=0, atol=1e-12)
    assert not np.allclose(r, np.eye(3))
    assert sim.time == pytest.approx(200 * sim.dt)
    assert sim.velocities[0, 2] < 0.0  # falling
