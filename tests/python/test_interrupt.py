"""step() and run() release the GIL (another thread runs meanwhile) and stop
at Ctrl-C with the world, or the run's outputs, consistent."""

import _thread
import json
import threading
import tomllib

import pytest

import lsdem


def interrupt_after(seconds):
    # Another Python thread: it can only run while step() or run() hold no GIL.
    timer = threading.Timer(seconds, _thread.interrupt_main)
    timer.start()
    return timer


def test_step_releases_the_gil_and_stops_at_ctrl_c(scene_path):
    sim = lsdem.Simulation(scene_path, threads=1)
    timer = interrupt_after(0.3)
    with pytest.raises(KeyboardInterrupt):
        sim.step(10**9)
    timer.join()
    done = sim.steps
    assert 0 < done < 10**9
    assert sim.step(10) == 10 and sim.steps == done + 10  # between two steps: it goes on


def test_run_stops_at_ctrl_c_with_its_checkpoint_and_resumes(tmp_path, scene_path):
    with open(scene_path, "rb") as f:
        scene = tomllib.load(f)
    scene["output"]["progress_seconds"] = 0.05  # Ctrl-C is looked for at each report
    out = tmp_path / "out"
    timer = interrupt_after(0.3)
    with pytest.raises(KeyboardInterrupt):
        lsdem.run(scene, out=out, threads=1)  # a dict: written to a temporary file for the run
    timer.join()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["stopped_early"] is True
    assert 0 < summary["steps"] and summary["simulated_time"] < 0.08
    assert (out / "checkpoint.lsc").is_file()
    # The temporary scene file is gone; the run's copy of it resumes.
    result = lsdem.run(resume=out, threads=1, steps=200)
    assert not result["stopped"] and result["steps"] == summary["steps"] + 200
    assert result["time"] > summary["simulated_time"]
