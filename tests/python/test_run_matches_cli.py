"""lsdem.run gives the command line's outputs: summary.json equal in every
key but the wall-clock ones, the breakage log and size distributions equal
byte for byte."""

import json
import subprocess

import lsdem
from conftest import SHORT_STEPS

# Keys whose values are wall-clock measurements (they differ between any two runs).
WALL_CLOCK_KEYS = {"wall_time", "steps_per_second", "seconds", "stage_seconds"}


def without_wall_clock(value):
    if isinstance(value, dict):
        return {k: without_wall_clock(v) for k, v in value.items()
                if k not in WALL_CLOCK_KEYS and not k.endswith("_seconds")}
    if isinstance(value, list):
        return [without_wall_clock(v) for v in value]
    return value


def test_run_gives_the_summary_of_the_command_line(tmp_path, scene_path, lsdem_binary):
    cli_out, py_out = tmp_path / "cli", tmp_path / "py"
    subprocess.run([lsdem_binary, "run", scene_path, "--out", str(cli_out), "--threads", "1", "-q",
                    "--steps", str(SHORT_STEPS)], check=True)
    result = lsdem.run(scene_path, out=py_out, steps=SHORT_STEPS, threads=1)

    cli = json.loads((cli_out / "summary.json").read_text())
    py = json.loads((py_out / "summary.json").read_text())
    # The run did something worth comparing: grains broke, contacts were made.
    assert cli["steps"] == SHORT_STEPS
    assert cli["breakage"]["breakages"] >= 2
    assert cli["contacts"] > 0
    assert set(cli) == set(py)
    assert without_wall_clock(py) == without_wall_clock(cli)
    # The wall-clock keys are there, only not compared.
    assert py["wall_time"] > 0.0 and "stage_seconds" in py

    assert result["steps"] == SHORT_STEPS
    assert result["out_dir"] == str(py_out)
    assert result["breakages"] == cli["breakage"]["breakages"]
    assert result["particles"] == cli["particles"]
    assert result["time"] == cli["simulated_time"]
    assert not result["stopped"]
    for name in ("breakage_log.csv", "psd.csv", "removed.csv"):
        assert (py_out / name).read_bytes() == (cli_out / name).read_bytes(), name


def test_run_refuses_bad_input_with_the_location(tmp_path):
    scene = tmp_path / "bad.toml"
    scene.write_text("[simulation]\ndimension = 2\nsteps = 10\n\n[contact]\nkn = 1e5\nfriction = -0.2\n")
    try:
        lsdem.run(scene, out=tmp_path / "out")
    except lsdem.InputError as e:
        assert isinstance(e, ValueError)
        assert str(e).startswith(f"{scene}:7: contact.friction: ")
        assert (e.file, e.line, e.key) == (str(scene), 7, "contact.friction")
        assert "-0.2" in e.problem
    else:
        raise AssertionError("no InputError")
    assert not (tmp_path / "out").exists()


def test_an_output_folder_of_another_run_is_refused_without_overwrite(tmp_path, scene_path):
    # (A folder name holding "--steps" stays as it is in the advice.)
    out = tmp_path / "a--steps" / "o"
    lsdem.run(scene_path, out=out, steps=5, threads=1)
    try:
        lsdem.run(scene_path, out=out, steps=5, threads=1)
    except lsdem.InputError as e:
        # The advice names run()'s arguments, not the command line's options.
        assert e.problem.endswith("give overwrite=True to replace them, or continue that run with resume=" +
                                  str(out)), e.problem
    else:
        raise AssertionError("no InputError")
    assert lsdem.run(scene_path, out=out, steps=7, threads=1, overwrite=True)["steps"] == 7
    for bad in (-1, 4097):
        try:
            lsdem.run(scene_path, out=tmp_path / "t", steps=1, threads=bad)
        except ValueError as e:
            assert "threads must be in [0, 4096]" in str(e), str(e)
        else:
            raise AssertionError("threads=%d accepted" % bad)


def test_resume_continues_the_run(tmp_path, scene_path):
    straight = lsdem.run(scene_path, out=tmp_path / "a", steps=400, threads=1)
    lsdem.run(scene_path, out=tmp_path / "b", steps=250, threads=1)
    resumed = lsdem.run(resume=tmp_path / "b", steps=150, threads=1)
    assert resumed["steps"] == straight["steps"] == 400
    assert resumed["time"] == straight["time"]


def test_progress_is_called_and_its_exception_stops_the_run(tmp_path, scene_path):
    reports = []
    lsdem.run(scene_path, out=tmp_path / "p", steps=50, threads=1, progress=reports.append)
    assert reports and reports[-1]["done"] and reports[-1]["steps"] == 50

    def fail(report):
        raise KeyError("stop here")

    try:
        lsdem.run(scene_path, out=tmp_path / "q", steps=50, threads=1, progress=fail)
    except KeyError as e:
        assert "stop here" in str(e)
    else:
        raise AssertionError("the progress callback's exception was lost")
