"""pytest suite for the perifx Python module (ctest "python": PYTHONPATH has build/python)."""
import json
import os
import pathlib
import subprocess

import numpy as np
import pytest

import perifx

SOURCE = pathlib.Path(os.environ.get("PERIFX_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
CLI = os.environ.get("PERIFX_CLI", str(SOURCE / "build" / "perifx"))
CANTILEVER = SOURCE / "assets" / "scenes" / "cantilever.json"
WALL = SOURCE / "tests" / "engine" / "data" / "resume_wall.json"


def small_scene(**overrides):
    scene = {
        "time": {"dt": 1e-4, "duration": 0.01, "frame_rate": 200},
        "materials": {"soft": {"density": 1000, "bulk_modulus": 1e5, "shear_modulus": 5e4}},
        "bodies": [{"name": "cube", "material": "soft",
                    "geometry": {"type": "box", "size": [0.1, 0.1, 0.1], "edge_length": 0.03}}],
    }
    scene.update(overrides)
    return scene


def test_world_from_dict_steps_and_counts():
    w = perifx.World(small_scene(), threads=1)
    assert w.particle_count > 0 and w.bond_count > 0
    assert w.step_count == 0 and w.time == 0.0
    w.step(5)
    assert w.step_count == 5
    assert w.time == pytest.approx(5 * w.dt)
    assert w.alive_bond_count == w.bond_count
    assert w.fragment_count == 1


def test_a_scene_without_a_step_gets_one_at_set_up():
    # "dt": "auto" (the default): 80 % of the stable limit at most, a whole number of steps per frame.
    w = perifx.World(small_scene(time={"duration": 0.01, "frame_rate": 200}), threads=1)
    steps = 1 / (200 * w.dt)
    assert abs(steps - round(steps)) < 1e-9 * steps
    assert w.dt <= 0.8 * w.stable_time_step()
    assert w.dt > 1e-4  # the soft cube's hand-picked step above was well inside its limit


def test_contact_takes_its_time_scale_from_the_scene_not_the_step():
    # contact/time_scale "auto": 80 % of the stable limit for a body nothing moves, whatever dt is given;
    # nothing touches without contact: 0.
    for dt in (1e-4, 5e-5):
        w = perifx.World(small_scene(time={"dt": dt, "duration": 0.01, "frame_rate": 200},
                                     contact={"enabled": True}), threads=1)
        assert w.contact_time_scale() == pytest.approx(0.8 * w.stable_time_step(), rel=1e-12)
    assert perifx.World(small_scene(), threads=1).contact_time_scale() == 0.0
    given = perifx.World(small_scene(contact={"enabled": True, "time_scale": 3e-4}), threads=1)
    assert given.contact_time_scale() == 3e-4


def test_fields_are_read_only_views_without_copies():
    w = perifx.World(str(CANTILEVER))
    names = w.field_names()
    assert "velocity" in names and "damage" in names
    for name in names:
        a = w.field(name)
        assert a.shape[0] == w.particle_count
        assert not a.flags.writeable
        assert not a.flags.owndata  # a view of the world's array
    y = w.positions()
    assert y.shape == (w.particle_count, 3) and y.dtype == np.float64
    with pytest.raises(ValueError):
        y[0, 0] = 1.0
    # Positions are the world's memory: stepping moves what the view shows.
    before = np.array(y)
    w.step(10)
    assert not np.array_equal(before, w.positions())
    with pytest.raises(KeyError, match="no field named 'nope'"):
        w.field("nope")


def test_view_keeps_its_world_alive():
    v = perifx.World(small_scene()).positions()
    import gc
    gc.collect()
    assert np.isfinite(v).all() and v.shape[1] == 3


def test_two_worlds_side_by_side():
    a = perifx.World(small_scene(), threads=1)
    b = perifx.World(small_scene(gravity=[0, 0, 0]), threads=2)
    a.step(20)
    b.step(20)
    assert np.all(b.velocities() == 0.0)          # no gravity, nothing moves
    assert np.all(a.velocities()[:, 1] < 0.0)     # falling
    c = perifx.World(small_scene(), threads=2)
    c.step(20)
    assert np.array_equal(a.positions(), c.positions())  # bit-identical on another thread count


def test_memory_by_kind_adds_up_and_grows_only_where_a_run_grows():
    # World::memory by kind: the parts sum to the total, the bond arrays are 5 B per directed bond in
    # an elastic, unbreakable world (components/bonds.hpp: neighbour + alive), and stepping an intact
    # cube changes nothing (no contact rows, no split mesh).
    w = perifx.World(small_scene(), threads=1)
    m = w.memory()
    kinds = ["particle_bytes", "bond_bytes", "mesh_bytes", "contact_bytes", "other_bytes"]
    assert sum(m[k] for k in kinds) == m["total_bytes"] == w.memory_bytes()
    assert m["bond_bytes"] >= 5 * w.bond_count and m["bond_bytes"] < 5.5 * w.bond_count
    w.step(20)
    assert w.memory() == m


def test_surface_and_pieces():
    w = perifx.World(str(WALL))
    w.step(80)  # the wall is in pieces from step 70
    s = w.surface()
    assert s["vertices"].shape[1] == 3 and s["triangles"].shape[1] == 3
    assert s["crack"].shape[0] == s["triangles"].shape[0] == s["fragment"].shape[0]
    assert s["crack"].any()                        # the ball has torn the wall
    pieces = w.pieces()
    assert pieces.shape == (w.particle_count,)
    assert len(np.unique(pieces)) == w.fragment_count > 1
    assert 0 < w.first_break_time <= w.time        # the wall broke, and the time says when


def test_errors_are_perifx_exceptions_with_one_line_messages(tmp_path):
    bad = small_scene(time={"dt": -1})
    with pytest.raises(perifx.SceneError) as e:
        perifx.World(bad)
    assert isinstance(e.value, perifx.Error)
    assert "/time/dt" in str(e.value) and "\n" not in str(e.value)
    with pytest.raises(perifx.Error, match="cannot open the scene file"):
        perifx.World(str(tmp_path / "missing.json"))


def test_run_matches_the_cli_bit_for_bit(tmp_path):
    cli_dir, py_dir = tmp_path / "cli", tmp_path / "py"
    subprocess.run([CLI, "run", str(WALL), "--out", str(cli_dir), "--quiet", "--frames", "5"], check=True)
    seen = []
    summary = perifx.run(str(WALL), out=str(py_dir), frames=5, threads=1, progress=lambda p: seen.append(p["frame"]))
    assert seen == [1, 2, 3, 4, 5]
    assert summary["frames"] == 5
    names = sorted(p.name for p in cli_dir.iterdir() if p.name != "summary.json")
    assert names == sorted(p.name for p in py_dir.iterdir() if p.name != "summary.json")
    for name in names:
        if name == "checkpoint.bin":
            continue
        assert (cli_dir / name).read_bytes() == (py_dir / name).read_bytes(), name
    # A second run into the same folder is refused unless asked.
    with pytest.raises(perifx.IoError, match="holds another run's output"):
        perifx.run(str(WALL), out=str(py_dir), frames=2)
    perifx.run(str(WALL), out=str(py_dir), frames=8, resume=True)
    assert json.loads((py_dir / "summary.json").read_text())["first_frame"] == 5


def test_progress_callback_can_stop_a_run(tmp_path):
    def stop(p):
        if p["frame"] == 2:
            raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        perifx.run(small_scene(), out=str(tmp_path / "run"), progress=stop)
    assert (tmp_path / "run" / "particles.0002.vtu").exists()
    assert not (tmp_path / "run" / "particles.0003.vtu").exists()


def test_checkpoint_round_trip(tmp_path):
    a = perifx.World(str(WALL))
    a.step(30)
    a.save_checkpoint(str(tmp_path / "c.bin"))
    a.step(30)
    b = perifx.World(str(WALL))
    b.load_checkpoint(str(tmp_path / "c.bin"))
    assert b.step_count == 30
    b.step(30)
    assert np.array_equal(a.positions(), b.positions())
    assert np.array_equal(a.field("damage"), b.field("damage"))


def test_ctrl_c_stops_a_run_with_a_checkpoint(tmp_path):
    import signal
    import threading
    out = tmp_path / "run"
    # Ctrl-C a moment after the first frame is written, from another thread as a terminal would: a
    # fixed delay from the start could land in the set-up on a loaded machine (last_frame 0; seen once
    # in a `ctest -j2` run, 2026-12-07).
    started = []

    def first_frame(p):
        if p["frame"] >= 1 and not started:
            started.append(threading.Timer(0.05, os.kill, (os.getpid(), signal.SIGINT)))
            started[0].start()
    with pytest.raises(KeyboardInterrupt):
        perifx.run(str(WALL), out=str(out), frames=400, progress=first_frame)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["interrupted"] and 0 < summary["last_frame"] < 400
    assert (out / "checkpoint.bin").exists()
    resumed = perifx.run(str(WALL), out=str(out), frames=summary["last_frame"] + 2, resume=True)
    assert resumed["first_frame"] == summary["last_frame"]


def test_profile_times_every_system_once_per_step(tmp_path):
    w = perifx.World(small_scene(), threads=1)
    assert all(t["steps"] == 0 for t in w.system_times())
    w.set_profiling(True)
    w.step(7)
    times = w.system_times()
    assert {"kick_begin", "dilatation", "bond_pass", "kick_end"} <= {t["system"] for t in times}
    assert all(t["steps"] == 7 and t["seconds"] >= 0.0 for t in times)
    s = perifx.run(small_scene(), out=tmp_path / "run", frames=2, threads=1, profile=True)
    assert [t["steps"] for t in s["profile"]] == [s["steps"]] * len(s["profile"])
    assert json.loads((tmp_path / "run" / "summary.json").read_text())["profile"][0]["steps"] == s["steps"]
