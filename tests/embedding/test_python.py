"""Python bindings (issue 8). Run by ctest with PYTHONPATH=<build>/python, from the source directory, and
PAPERTEAR_CLI naming the build's command line (the module's batch and writers are compared with it)."""
import contextlib
import copy
import glob
import io
import json
import os
import pathlib
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
import unittest

import numpy as np

import papertear

SOURCE = pathlib.Path(os.environ.get("PAPERTEAR_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
SCENARIO = str(SOURCE / "scenarios" / "start-inward.json")
CLI = os.environ.get("PAPERTEAR_CLI", str(SOURCE / "build" / "bin" / "papertear"))


def readme_block(lang):
    """The first ```lang block of README.md's '## Embedding' section."""
    text = (SOURCE / "README.md").read_text()
    section = text[text.index("\n## Embedding\n"):]
    start = section.index("\n```" + lang + "\n") + len("\n```" + lang + "\n")
    return section[start:section.index("\n```", start) + 1]


class Bindings(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.sim = papertear.Simulation(SCENARIO, threads=2)

    def test_import(self):
        self.assertRegex(papertear.__version__, r"^[0-9]+\.[0-9]+\.[0-9]+$")
        self.assertTrue(issubclass(papertear.InputError, ValueError))
        self.assertTrue(issubclass(papertear.GeometryError, ValueError))
        self.assertEqual(papertear.load_scenario(SCENARIO).name, "start-inward")

    def test_shapes_and_dtypes(self):
        sim = papertear.Simulation(papertear.load_scenario(SCENARIO), threads=1)
        x, r, t = sim.positions, sim.rest, sim.triangles
        n, m = x.shape[0], t.shape[0]
        self.assertGreater(n, 3)
        self.assertEqual(x.shape, (n, 3))
        self.assertEqual(r.shape, (n, 2))
        self.assertEqual(t.shape[1], 3)
        self.assertEqual((x.dtype, r.dtype, t.dtype), (np.float64, np.float64, np.int32))
        self.assertEqual(sim.triangle_pieces.shape, (m,))
        self.assertTrue(((t >= 0) & (t < n)).all())
        self.assertFalse(x.flags.writeable)
        self.assertFalse(x.flags.owndata)
        # The flat sheet: z = 0 and x, y equal the pattern coordinates at rest.
        np.testing.assert_allclose(x[:, :2], r)
        self.assertEqual(sim.pieces, 1)
        self.assertEqual(sim.tears, [])

    def test_scenario_edited_in_code(self):
        sc = papertear.load_scenario(SCENARIO)
        sc.triangles = 150
        sc.validate()
        sim = papertear.Simulation(sc, threads=1)
        self.assertLess(sim.triangles.shape[0], 250)
        with self.assertRaises(papertear.InputError):
            sc.fps = -1.0  # refused when set, the scenario unchanged
        self.assertEqual(sc.fps, 30.0)
        sc.validate()
        with self.assertRaises(ValueError):
            papertear.Simulation(SCENARIO, threads=0)

    def test_relaxation_choice(self):
        sc = papertear.load_scenario(SCENARIO)
        self.assertEqual((sc.relaxation, sc.relaxation_radius), ("substep", 0.03))
        sc.relaxation = "patch"
        sc.relaxation_radius = 0.05
        sc.validate()
        sim = papertear.Simulation(sc, threads=1)
        sim.step(5)
        self.assertEqual(sim.frame, 5)
        with self.assertRaises(papertear.InputError):
            sc.relaxation = "everywhere"
        self.assertEqual(sc.relaxation, "patch")
        # The settings of `papertear --set`, written into the file's JSON before it is read.
        sc = papertear.load_scenario(SCENARIO, ["sim.relaxation=patch", "sim.relaxation_radius=0.04"])
        self.assertEqual((sc.relaxation, sc.relaxation_radius), ("patch", 0.04))
        with self.assertRaises(papertear.InputError):
            papertear.load_scenario(SCENARIO, ["sim.relaxation_radius=-1"])

    def test_step_splitting_settings(self):
        sc = papertear.load_scenario(SCENARIO)
        self.assertEqual((sc.step_splits, sc.split_strain_jump), (3, 0.0025))
        sc.step_splits = 0
        sc.split_strain_jump = 0.01
        sc.validate()
        self.assertEqual(papertear.load_scenario(SCENARIO, ["sim.step_splits=0"]).step_splits, 0)
        with self.assertRaises(papertear.InputError):
            sc.step_splits = 9
        self.assertEqual(sc.step_splits, 0)

    def test_view_follows_stepping(self):
        sim = papertear.Simulation(SCENARIO, threads=2)
        x = sim.positions
        before = x.copy()
        ptr = x.__array_interface__["data"][0]
        sim.step()
        self.assertEqual(sim.positions.__array_interface__["data"][0], ptr)  # a view of the same memory
        self.assertGreater(np.abs(x - before).max(), 0.0)  # changed without re-fetching
        self.assertEqual(sim.frame, 1)
        # Across tears (topology changes) the old view keeps its shape and stays readable; fresh views
        # have the new row count.
        tri = sim.triangles
        sim.step(30)
        self.assertGreater(sim.topology_version, 1)
        self.assertEqual(x.shape, before.shape)
        self.assertTrue(np.isfinite(x).all())
        self.assertEqual(sim.positions.shape[0], sim.rest.shape[0])
        self.assertLess(int(sim.triangles.max()), sim.positions.shape[0])
        self.assertGreater(np.abs(x - sim.positions[: x.shape[0]]).max(), -1.0)  # old view still readable
        del tri

    def test_bad_scenario_raises_input_error_with_path(self):
        with tempfile.TemporaryDirectory() as d:
            bad = pathlib.Path(d) / "bad.json"
            doc = json.loads(pathlib.Path(SCENARIO).read_text())
            doc["sheet"]["triangles"] = "many"
            bad.write_text(json.dumps(doc))
            with self.assertRaises(papertear.InputError) as err:
                papertear.load_scenario(str(bad))
            self.assertIn(str(bad), str(err.exception))
            self.assertIn("sheet.triangles", str(err.exception))
            with self.assertRaises(ValueError):
                papertear.Simulation(bad)  # os.PathLike too
        with self.assertRaises(papertear.InputError) as err:
            papertear.load_scenario(str(SOURCE / "does-not-exist.json"))
        self.assertIn("does-not-exist.json", str(err.exception))

    def test_tears_events_timings_hash(self):
        sim = papertear.Simulation(SCENARIO, threads=2)
        sim.step(60)
        # Same scenario, one thread: same state (thread-independent hash).
        one = papertear.Simulation(SCENARIO, threads=1)
        one.step(60)
        self.assertEqual(one.hash, sim.hash)
        sim.flush()
        tears = sim.tears
        self.assertGreaterEqual(len(tears), 1)
        t = tears[0]
        self.assertEqual(set(t), {"id", "parent", "kind", "frame", "uv", "tips", "detail", "reached_boundary",
                                  "max_advance_per_frame"})
        self.assertIn(t["kind"], ("finger", "junction", "inward"))
        self.assertEqual(len(t["uv"]), 2)
        kinds = [e["kind"] for e in sim.events]
        self.assertIn("tear_started", kinds)
        self.assertTrue(set(kinds) <= {"tear_started", "tear_extended", "piece_separated"})
        started = [e for e in sim.events if e["kind"] == "tear_started"]
        self.assertEqual(len(started), len(tears))
        tm = sim.timings
        self.assertEqual(tm["frame"]["count"], 60)
        self.assertGreater(tm["frame"]["avg"], 0.0)
        self.assertIn("propagation", tm["systems"])
        self.assertRegex(sim.hash, r"^[0-9a-f]+$")
        # After the topology changed, fresh views are consistent with the new mesh.
        x, tri = sim.positions, sim.triangles
        self.assertLess(int(tri.max()), x.shape[0])
        self.assertTrue(np.isfinite(x).all())
        res = sim.result()
        self.assertEqual(res["hash"], sim.hash)
        self.assertEqual(len(res["tears"]), len(tears))
        self.assertGreater(len(tears[0]["detail"]), 1)  # carved after flush()

    def test_fingers(self):
        sim = papertear.Simulation(SCENARIO, threads=2)
        n0 = sim.positions.shape[0]
        i = sim.attach_finger("C", (0.074, 0.05))
        self.assertEqual(i, len(sim.fingers) - 1)
        self.assertEqual(sim.fingers[i]["name"], "C")
        self.assertGreaterEqual(sim.positions.shape[0], n0)  # a vertex may be inserted: fetch views again
        sim.move_finger(i, (0.074, 0.05, 0.01))
        sim.step()
        v = sim.fingers[i]["vertex"]
        np.testing.assert_allclose(sim.positions[v], (0.074, 0.05, 0.01), atol=1e-9)
        sim.release_finger(i)
        self.assertTrue(sim.fingers[i]["released"])
        sim.step()
        with self.assertRaises(ValueError):
            sim.attach_finger("D", (5.0, 5.0))
        with self.assertRaises(IndexError):
            sim.move_finger(99, (0, 0, 0))

    def test_thread_counts_outside_the_cap_are_refused(self):
        for bad in (0, 1025, 100000):
            with self.assertRaisesRegex(ValueError, "threads must be 1 to 1024"):
                papertear.Simulation(SCENARIO, threads=bad)

    def test_bad_finger_and_target_are_refused(self):
        # Issue 27: before, NaN, inf and 1e300 were keyed; 999 raised "vector::_M_range_check", -1 showed
        # 18446744073709551615.
        sim = papertear.Simulation(SCENARIO, threads=1)
        n = len(sim.fingers)
        for bad in (999, -1, n, 2**40):
            with self.assertRaises(IndexError) as err:
                sim.move_finger(bad, (0, 0, 0))
            self.assertEqual(str(err.exception), f"move_finger: no finger {bad} (the sheet has fingers 0 to {n - 1})")
            with self.assertRaises(IndexError):
                sim.release_finger(bad)
        name = sim.fingers[0]["name"]
        for target in ((float("nan"), 0, 0), (0, float("inf"), 0), (0, 0, -float("inf")), (1e300, 0, 0)):
            with self.assertRaises(papertear.InputError) as err:
                sim.move_finger(0, target)
            self.assertTrue(str(err.exception).startswith(f"move_finger: finger 0 ({name}): target "), str(err.exception))
        sim.step()
        for f in sim.fingers:
            self.assertTrue(np.all(np.isfinite(sim.positions[f["vertex"]])), f["name"])


class Threads(unittest.TestCase):
    """Issue 27: one Simulation used from two threads corrupted the heap ("malloc(): invalid size", both
    stepping) or segfaulted (one stepping, one reading). Calls are serialised by the simulation's lock."""

    def run_threads(self, *targets):
        errors = []

        def guarded(target):
            try:
                target()
            except BaseException as e:  # noqa: BLE001 - any exception in a thread is a failure here
                errors.append(e)

        threads = [threading.Thread(target=guarded, args=(t,)) for t in targets]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        self.assertEqual(errors, [])

    def reference_hash(self, frames):
        sim = papertear.Simulation(SCENARIO, threads=2)
        sim.step(frames)
        return sim.hash

    def test_two_threads_stepping_one_simulation(self):
        sim = papertear.Simulation(SCENARIO, threads=2)

        def stepper():
            for _ in range(20):
                sim.step()

        self.run_threads(stepper, stepper)
        # Whole frames one after the other: the state of 40 frames stepped by one thread.
        self.assertEqual(sim.frame, 40)
        self.assertEqual(sim.hash, self.reference_hash(40))

    def test_reading_while_another_thread_steps(self):
        sim = papertear.Simulation(SCENARIO, threads=2)
        reading, done = threading.Event(), threading.Event()
        frames_seen = set()

        def stepper():
            try:
                reading.wait()
                for _ in range(4):
                    sim.step(10)
            finally:
                done.set()

        def reader():
            reading.set()
            while not done.is_set():
                before = sim.frame
                frames_seen.add(before)
                tears, x, res = sim.tears, sim.positions, sim.result()
                # Each call is one read: a step(10) may come between two of them, and then the tears may
                # differ. Read at one frame, they agree.
                if sim.frame == before:
                    self.assertEqual(len(res["tears"]), len(tears))
                self.assertTrue(np.isfinite(x).all())
                sim.events, sim.fingers, sim.triangles, sim.hash

        self.run_threads(stepper, reader)
        # A read waits for the step(10) in progress: it sees the frames between the calls, never one inside.
        self.assertTrue(frames_seen <= {0, 10, 20, 30, 40}, sorted(frames_seen))
        self.assertEqual(sim.frame, 40)
        self.assertEqual(sim.hash, self.reference_hash(40))

    def test_a_signal_handler_using_the_stepping_simulation_is_refused(self):
        # The handler runs between two frames of step(), on the thread holding the lock: waiting for it
        # would never end, so the call is refused with a RuntimeError that step() then raises.
        sim = papertear.Simulation(SCENARIO, threads=1)
        previous = signal.signal(signal.SIGALRM, lambda *_: sim.frame)
        try:
            signal.setitimer(signal.ITIMER_REAL, 0.2)
            with self.assertRaisesRegex(RuntimeError, "called again from inside one of its own calls"):
                sim.step(3000)
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)
        self.assertLess(sim.frame, 3000)
        sim.step()  # still usable


class Interrupt(unittest.TestCase):
    def test_ctrl_c_stops_step_between_frames(self):
        # Issue 27: step(3000) released the GIL for all its frames, so Ctrl-C came after the last one
        # (22 s later). Now KeyboardInterrupt comes after the frame in progress, and the sheet goes on.
        sim = papertear.Simulation(SCENARIO, threads=1)
        # As an interactive session has it (a background job starts with SIGINT ignored).
        previous = signal.signal(signal.SIGINT, signal.default_int_handler)
        timer = threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT))
        try:
            start = time.monotonic()
            timer.start()
            with self.assertRaises(KeyboardInterrupt):
                sim.step(3000)
            seconds = time.monotonic() - start
        finally:
            timer.cancel()
            signal.signal(signal.SIGINT, previous)
        self.assertGreater(sim.frame, 0)
        self.assertLess(sim.frame, 3000, f"interrupted after {seconds:.1f} s")
        frames = sim.frame
        sim.step(2)
        reference = papertear.Simulation(SCENARIO, threads=1)
        reference.step(frames + 2)
        self.assertEqual(sim.hash, reference.hash)


def cli(*args, cwd=None):
    """Runs the build's command line; returns its stdout (fails the test on a non-zero exit)."""
    done = subprocess.run([CLI, *map(str, args)], cwd=cwd, capture_output=True, text=True, timeout=600)
    if done.returncode != 0:
        raise AssertionError(f"papertear {' '.join(map(str, args))}: exit {done.returncode}: {done.stderr}")
    return done.stdout


def one_line(test, err):
    text = str(err.exception)
    test.assertTrue(text and "\n" not in text, repr(text))
    return text


# Keys of result.json and batch.json that hold timings (docs/result-format.md), or the thread count.
RESULT_TIMINGS = {"timings_ms", "systems_ms", "solver_ms", "threads"}
BATCH_TIMINGS = {"wall_s", "sheet_frames_per_s", "timings_ms", "throughput"}


class ScenarioInCode(unittest.TestCase):
    """Issue 23: a scenario built in code, every value validated by the engine's parser as a file's."""

    def test_defaults_are_those_of_a_file(self):
        sc = papertear.Scenario()
        self.assertEqual((sc.preset, sc.triangles, sc.frames, sc.fps, sc.fingers), ("A4", 400, 90, 30.0, []))
        self.assertEqual(sc.path, "")
        sc.add_finger("A", (0.1, 0.1))
        text = '{"sheet": {"preset": "A4"}, "fingers": [{"name": "A", "at": [0.1, 0.1]}]}'
        self.assertEqual(sc, papertear.parse_scenario(text, ""))
        self.assertEqual(papertear.Scenario("A5").sheet_size, (0.148, 0.21))

    def test_every_shipped_scenario_round_trips(self):
        for path in sorted(glob.glob(str(SOURCE / "scenarios" / "*.json"))):
            sc = papertear.load_scenario(path)
            back = papertear.Scenario.from_dict(sc.to_dict(), path)
            self.assertEqual(back, sc, path)
            self.assertEqual(papertear.parse_scenario(sc.to_json(), path), sc, path)
            self.assertEqual(json.loads(back.to_json()), sc.to_dict(), path)
        a = papertear.Simulation(SCENARIO, threads=1)
        b = papertear.Simulation(papertear.Scenario.from_dict(papertear.load_scenario(SCENARIO).to_dict()), threads=1)
        a.step(20)
        b.step(20)
        self.assertEqual(a.hash, b.hash)

    def test_a_refused_value_has_the_files_message_and_changes_nothing(self):
        sc = papertear.Scenario()
        sc.add_finger("A", (0.1, 0.1))
        before = sc.to_dict()
        cases = [
            ("sheet.triangles", 1), ("sheet.triangles", "many"), ("sheet.triangles", 2.5),
            ("material.young", -1.0), ("material.yung", 4e9), ("sim.frames", 0), ("detail.omega", 2.0),
            ("tearing.direction", "sideways"), ("sim.solver", "magic"), ("fingers[0].grip", 0),
            ("fingers[0].at", [5.0, 5.0]), ("sheet.preset", "B7"), ("name", "a/b"),
        ]
        for key, value in cases:
            with self.subTest(key=key, value=value):
                with self.assertRaises(papertear.InputError) as err:
                    sc.set(key, value)
                text = one_line(self, err)
                # The message a file with that value gets.
                doc = copy.deepcopy(before)
                node = doc
                parts = key.replace("[0]", ".0").split(".")
                for part in parts[:-1]:
                    node = node[int(part)] if part.isdigit() else node[part]
                node[parts[-1]] = value
                with self.assertRaises(papertear.InputError) as file_err:
                    papertear.parse_scenario(json.dumps(doc), "")
                self.assertEqual(text, str(file_err.exception))
                self.assertTrue(text.startswith("<scenario>: "), text)
                self.assertEqual(sc.to_dict(), before)
        with self.assertRaises(papertear.InputError) as err:
            sc.triangles = 1
        self.assertEqual(str(err.exception), "<scenario>: sheet.triangles: must be at least 2, got 1")
        self.assertEqual(sc.triangles, 400)
        # A loaded scenario's messages name its file.
        loaded = papertear.load_scenario(SCENARIO)
        with self.assertRaises(papertear.InputError) as err:
            loaded.material.fracture_c = 1.0
        self.assertTrue(str(err.exception).startswith(SCENARIO + ": material.fracture_c: "), str(err.exception))

    def test_writable_fields(self):
        sc = papertear.Scenario()
        sc.preset = "A5"
        sc.triangles = 200
        sc.mesh_seed = 3
        sc.fiber_seed = 7
        sc.frames, sc.substeps, sc.dt = 12, 5, 1 / 60
        sc.material.young = 5e9
        sc.material.fracture_c = 3e4
        sc.tearing.radius = 0.05
        sc.detail.sigma, sc.detail.omega = 2e-3, 0.25
        sc.add_finger("L", (0.05, 0.2), keys=[(0.0, (0.05, 0.2, 0.0)), (0.4, (0.0, 0.2, 0.05))])
        sc.add_finger("R", (0.1, 0.2), keys=[(0.0, (0.1, 0.2, 0.0)), (0.4, (0.15, 0.2, 0.05))], grip=20.0,
                      pad=0.005, interpolation="smooth")
        with self.assertRaises(papertear.InputError) as err:
            sc.add_finger("S", (0.12, 0.2), interpolation="cubic")
        self.assertIn("fingers[2].interpolation: unknown interpolation \"cubic\"", str(err.exception))
        sc.finger("L").grip = 12.0
        d = sc.to_dict()
        self.assertEqual(d["sheet"], {"preset": "A5", "triangles": 200, "mesh_seed": 3, "mesh_rotation_deg": 0.0,
                                      "hand_lines": False})
        self.assertEqual((d["material"]["young"], d["material"]["fracture_c"], d["material"]["fiber_seed"]), (5e9, 3e4, 7))
        self.assertEqual((d["sim"]["frames"], d["sim"]["substeps"], d["sim"]["fps"]), (12, 5, 60.0))
        self.assertEqual((d["detail"]["sigma"], d["detail"]["omega"], d["tearing"]["radius"]), (2e-3, 0.25, 0.05))
        self.assertEqual([f["grip"] for f in sc.fingers], [12.0, 20.0])
        self.assertEqual([f.get("pad") for f in sc.fingers], [None, 0.005])
        self.assertEqual([f.get("interpolation") for f in sc.fingers], [None, "smooth"])
        self.assertEqual(sc.material.young, 5e9)
        self.assertEqual(sc.get("fingers[1].name"), "R")
        with self.assertRaises(AttributeError):
            sc.material.yung
        sc.sheet_size = (0.3, 0.25)  # a rectangle at the origin in place of the preset
        self.assertEqual((sc.preset, sc.outline), ("", [(0.0, 0.0), (0.3, 0.0), (0.3, 0.25), (0.0, 0.25)]))
        sc.update({"sim": {"frames": 33, "relaxation": "substep"}})
        with self.assertRaises(papertear.InputError):
            sc.update({"sim": {"frames": 44, "fps": -1}})  # all or nothing
        self.assertEqual((sc.to_dict()["sim"]["frames"], sc.relaxation), (33, "substep"))
        sc.remove_finger("R")
        self.assertEqual([f["name"] for f in sc.fingers], ["L"])

    def test_a_scenario_built_in_code_runs_as_its_file_does(self):
        sc = papertear.Scenario("A6")
        sc.name = "built-in-code"
        sc.triangles, sc.frames = 150, 8
        sc.add_finger("L", (0.03, 0.14), keys=[(0.0, (0.03, 0.14, 0.0)), (0.3, (0.0, 0.14, 0.04))])
        sc.add_finger("R", (0.07, 0.14), keys=[(0.0, (0.07, 0.14, 0.0)), (0.3, (0.1, 0.14, 0.04))])
        with tempfile.TemporaryDirectory() as d:
            path = pathlib.Path(d) / "built.json"
            path.write_text(sc.to_json())
            cli("run", path, "--out", pathlib.Path(d) / "out", "--threads", 1)
            result = json.loads((pathlib.Path(d) / "out" / "result.json").read_text())
        sim = papertear.Simulation(sc, threads=1)
        sim.step(8)
        self.assertEqual(result["hash"], sim.hash)

    def test_no_fingers_in_code_only(self):
        sc = papertear.Scenario()
        sim = papertear.Simulation(sc, threads=1)  # a sheet falling freely
        sim.step(2)
        self.assertEqual(sim.attach_finger("A", (0.1, 0.1)), 0)
        with self.assertRaises(papertear.InputError) as err:
            papertear.parse_scenario(sc.to_json(), "file.json")  # a file needs fingers
        self.assertIn("fingers", str(err.exception))


class BadArguments(unittest.TestCase):
    """Issue 23: wrong types, NaN, negative counts and unknown keys are one line, never a crash or a listing."""

    def test_from_dict(self):
        good = papertear.Scenario().to_dict()
        for change, where in [
            ({"sheet": {"preset": "A4", "colour": "red"}}, "<scenario>: sheet.colour: unknown key"),
            ({"sim": {"fps": float("nan")}}, "<scenario>: sim.fps: expected a finite number"),
            ({"sim": {"fps": float("inf")}}, "<scenario>: sim.fps: expected a finite number"),
            ({"sim": {"frames": -5}}, "<scenario>: sim.frames: must be at least 1"),
            ({"sheet": {"preset": "A4", "triangles": 2**80}}, "<scenario>: sheet.triangles: absurd size"),
            ({"material": {1: 2}}, "<scenario>: material: keys must be strings"),
            ({"sim": {"gravity": {0, 1, 2}}}, "<scenario>: sim.gravity: expected a JSON value"),
            ({"fingers": [{"name": "A"}]}, "<scenario>: fingers[0]: missing at"),
        ]:
            doc = copy.deepcopy(good)
            for k, v in change.items():
                doc[k] = v
            with self.subTest(change=change):
                with self.assertRaises(papertear.InputError) as err:
                    papertear.Scenario.from_dict(doc)
                self.assertTrue(one_line(self, err).startswith(where), str(err.exception))
        with self.assertRaises(TypeError) as err:
            papertear.Scenario.from_dict([1, 2])
        one_line(self, err)

    def test_simulation_arguments(self):
        for bad, error in [("x", TypeError), (2.5, TypeError), (True, TypeError), (0, ValueError), (-3, ValueError),
                           (2**40, ValueError), (None, TypeError)]:
            with self.subTest(threads=bad):
                with self.assertRaises(error) as err:
                    papertear.Simulation(SCENARIO, threads=bad)
                one_line(self, err)
        for bad in (b"scenarios/start-inward.json", 42):
            with self.assertRaises(TypeError) as err:
                papertear.Simulation(bad)
            one_line(self, err)
        sim = papertear.Simulation(SCENARIO, threads=1)
        for bad, error in [(-1, ValueError), ("2", TypeError), (2.0, TypeError), (2**70, ValueError)]:
            with self.subTest(n=bad):
                with self.assertRaises(error) as err:
                    sim.step(bad)
                one_line(self, err)
        self.assertEqual(sim.frame, 0)
        for call in (lambda: sim.attach_finger(3, (0.1, 0.1)), lambda: sim.attach_finger("C", "ab"),
                     lambda: sim.attach_finger("C", (0.1,)), lambda: sim.move_finger("0", (0, 0, 0)),
                     lambda: sim.move_finger(0, None), lambda: sim.release_finger(1.5)):
            with self.assertRaises(TypeError) as err:
                call()
            one_line(self, err)
        with self.assertRaises(ValueError) as err:
            sim.attach_finger("C", (float("nan"), 0.1))
        one_line(self, err)
        with self.assertRaises(TypeError):
            sim.write_svg(123)
        with self.assertRaises(ValueError):
            sim.write_obj("frame.png", textured=True)
        with self.assertRaises(OSError) as err:
            sim.write_svg(str(SOURCE / "no-such-directory" / "pattern.svg"))
        one_line(self, err)

    def test_run_batch_arguments(self):
        for kwargs, error, start in [
            (dict(sheets=0), ValueError, "sheets must be 1 to 1000000"),
            (dict(sheets=-3), ValueError, "sheets must be"),
            (dict(sheets="3"), TypeError, "sheets must be an integer"),
            (dict(sheets=2, vary=["nope=1:2"]), papertear.InputError, "vary nope=1:2: unknown key 'nope'"),
            (dict(sheets=2, vary=["material.young=1e9"]), papertear.InputError, "vary material.young=1e9: expected"),
            (dict(sheets=2, vary=[("material.young", float("nan"), 1.0)]), ValueError, "vary[0] from must be a finite"),
            (dict(sheets=2, vary="material.young=1:2"), TypeError, "vary must be a list"),
            (dict(sheets=2, threads=0), ValueError, "threads must be 1 to 1024"),
            (dict(sheets=2, frames=0), ValueError, "frames must be 1 to"),
            (dict(sheets=2, fixed_seeds=1), TypeError, "fixed_seeds must be True or False"),
            (dict(sheets=3, vary=["material.poisson=0.1:0.7"]), papertear.InputError, SCENARIO),
        ]:
            with self.subTest(kwargs=kwargs):
                with self.assertRaises(error) as err:
                    papertear.run_batch(SCENARIO, **kwargs)
                self.assertTrue(one_line(self, err).startswith(start), str(err.exception))


class Threads1000(unittest.TestCase):
    """Issue 23: Simulation(path, threads=1000) passed 1000 to TBB (its warning on stderr, .threads 1000); the
    count is capped at the CPUs as the command line's --threads is."""

    def test_threads_above_the_cpus_are_capped_and_said(self):
        cpus = len(os.sched_getaffinity(0))
        code = ("import warnings, papertear\n"
                "with warnings.catch_warnings(record=True) as w:\n"
                "    warnings.simplefilter('always')\n"
                f"    sim = papertear.Simulation({SCENARIO!r}, threads=1000)\n"
                "    sim.step(2)\n"
                "print(sim.threads)\n"
                "print(*[f'{x.category.__name__}: {x.message}' for x in w], sep='\\n')\n")
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
        self.assertEqual(done.returncode, 0, done.stderr)
        self.assertEqual(done.stderr, "")  # no "TBB Warning: The number of workers is currently limited"
        lines = done.stdout.splitlines()
        used = int(lines[0])  # TBB's count of the CPUs this process may use
        self.assertTrue(1 <= used <= min(1000, cpus), lines)
        if used < 1000:
            cpu_word = "CPU" if used == 1 else "CPUs"
            self.assertEqual(lines[1:], [f"RuntimeWarning: threads=1000 capped at the {used} {cpu_word} available"])


class Writers(unittest.TestCase):
    """Issue 23: the files of `papertear run --svg --png --obj`, byte for byte (result.json apart from timings)."""

    FRAMES = 30

    def test_bytes_equal_the_command_lines(self):
        with tempfile.TemporaryDirectory() as d:
            d = pathlib.Path(d)
            cli("run", SCENARIO, "--frames", self.FRAMES, "--threads", 1, "--svg", "--png", "--obj", "--out", d / "cli")
            sim = papertear.Simulation(SCENARIO, threads=1)
            (d / "py" / "frames").mkdir(parents=True)
            for _ in range(self.FRAMES):
                sim.step()
                sim.write_obj(d / "py" / "frames" / f"frame_{sim.frame:04d}.obj", textured=True)
            self.assertGreaterEqual(len(sim.tears), 1)
            self.assertTrue(sim.write_result(d / "py" / "result.json"))
            sim.write_svg(d / "py" / "pattern.svg")
            sim.write_png(d / "py" / "pattern.png")
            for name in ("pattern.svg", "pattern.png"):
                self.assertEqual((d / "py" / name).read_bytes(), (d / "cli" / name).read_bytes(), name)
            frames = sorted(p.name for p in (d / "cli" / "frames").iterdir())
            self.assertEqual(sorted(p.name for p in (d / "py" / "frames").iterdir()), frames)
            self.assertIn("paper.png", frames)
            self.assertTrue(any(f.startswith("carved_") for f in frames), frames)
            for name in frames:
                self.assertEqual((d / "py" / "frames" / name).read_bytes(), (d / "cli" / "frames" / name).read_bytes(), name)
            py, ref = (json.loads((d / k / "result.json").read_text()) for k in ("py", "cli"))
            self.assertEqual(list(py), list(ref))
            self.assertEqual({k: v for k, v in py.items() if k not in RESULT_TIMINGS},
                             {k: v for k, v in ref.items() if k not in RESULT_TIMINGS})
            self.assertEqual(py["hash"], sim.hash)
        # Untextured: one OBJ of the mesh now.
        with tempfile.TemporaryDirectory() as d:
            sim.write_obj(pathlib.Path(d) / "mesh.obj")
            text = (pathlib.Path(d) / "mesh.obj").read_text()
            self.assertEqual(text.count("\nf "), sim.triangles.shape[0])


class Batch(unittest.TestCase):
    """Issue 23: run_batch is `papertear batch`: the same hashes, batch.csv and batch.json (apart from timings)."""

    def compare_with_cli(self, cli_args, **kwargs):
        with tempfile.TemporaryDirectory() as d:
            d = pathlib.Path(d)
            cli("batch", *cli_args, "--out", d / "cli")
            res = papertear.run_batch(out=d / "py", **kwargs)
            self.assertEqual(res["written"], [str(d / "py" / "batch.json"), str(d / "py" / "batch.csv")])
            py, ref = (json.loads((d / k / "batch.json").read_text()) for k in ("py", "cli"))
            self.assertEqual(res["hashes"], ref["hashes"])
            self.assertEqual([o["hash"] for o in res["outcomes"]], ref["hashes"])
            drop = lambda doc: {k: ([{x: y for x, y in o.items() if x != "frame_ms"} for o in v] if k == "outcomes" else v)
                                for k, v in doc.items() if k not in BATCH_TIMINGS}
            self.assertEqual(drop(py), drop(ref))
            # The outcomes of batch.json, each with its sheet's hash.
            self.assertEqual([{k: v for k, v in o.items() if k not in ("frame_ms", "hash")} for o in res["outcomes"]],
                             [{k: v for k, v in o.items() if k != "frame_ms"} for o in ref["outcomes"]])
            for k in ("scenario", "sheets", "threads", "frames", "vary", "fixed_seeds"):
                self.assertEqual(res[k], ref[k], k)
            csv_py, csv_cli = ((d / k / "batch.csv").read_text().splitlines() for k in ("py", "cli"))
            column = csv_cli[0].split(",").index("frame_ms")
            strip = lambda rows: [",".join(c for i, c in enumerate(r.split(",")) if i != column) for r in rows]
            self.assertEqual(strip(csv_py), strip(csv_cli))
            return res

    def test_hashes_equal_the_command_lines(self):
        res = self.compare_with_cli(
            [SCENARIO, "--sheets", 3, "--frames", 12, "--threads", 2, "--vary", "material.fracture_c=2e4:3e4"],
            scenario=SCENARIO, sheets=3, frames=12, threads=2, vary=["material.fracture_c=2e4:3e4"])
        self.assertEqual([o["values"] for o in res["outcomes"]],
                         [{"material.fracture_c": v} for v in (2e4, 2.5e4, 3e4)])
        self.assertEqual(len(set(res["hashes"])), 3)
        # A Scenario, (key, from, to), fixed seeds and --set; the hashes do not depend on the threads.
        sc = papertear.load_scenario(SCENARIO, ["sim.substeps=8"])
        res = self.compare_with_cli(
            [SCENARIO, "--sheets", 2, "--frames", 10, "--threads", 2, "--fixed-seeds", "--set", "sim.substeps=8",
             "--vary", "detail.sigma=0.001:0.002"],
            scenario=sc, sheets=2, frames=10, threads=2, fixed_seeds=True, vary=[("detail.sigma", 0.001, 0.002)])
        self.assertTrue(all(o["fiber_seed"] == sc.fiber_seed for o in res["outcomes"]))
        again = papertear.run_batch(SCENARIO, 2, frames=10, threads=1, fixed_seeds=True, settings=["sim.substeps=8"],
                                    vary=["detail.sigma=0.001:0.002"])
        self.assertEqual(again["hashes"], res["hashes"])
        self.assertEqual(again["written"], [])


class PythonDoc(unittest.TestCase):
    def test_docs_python_examples_run(self):
        text = (SOURCE / "docs" / "python.md").read_text()
        blocks = re.findall(r"\n```python\n(.*?)\n```", text, re.S)
        self.assertEqual(len(blocks), 3)
        out = io.StringIO()
        cwd = os.getcwd()
        with tempfile.TemporaryDirectory() as d:
            os.symlink(SOURCE / "scenarios", pathlib.Path(d) / "scenarios")
            os.chdir(d)
            try:
                scope = {"__name__": "__main__"}
                with contextlib.redirect_stdout(out):
                    for code in blocks:
                        exec(compile(code, "docs/python.md", "exec"), scope)
                written = sorted(str(p.relative_to(d)) for p in pathlib.Path(d, "out").rglob("*") if p.is_file())
                papertear.load_scenario("mine.json")
            finally:
                os.chdir(cwd)
        lines = out.getvalue().splitlines()
        self.assertEqual(lines[0], "<scenario>: sheet.triangles: must be at least 2, got 1")
        self.assertEqual(len(lines), 9)  # and one line per sheet
        for name in ("out/result.json", "out/pattern.svg", "out/pattern.png", "out/frames/paper.png",
                     "out/frames/frame_0060.obj", "out/sweep/batch.json", "out/sweep/batch.csv"):
            self.assertIn(name, written)


class Readme(unittest.TestCase):
    def test_readme_python_example_runs(self):
        code = readme_block("python")
        self.assertEqual(code, (SOURCE / "examples" / "python" / "tear.py").read_text(),
                         "README '## Embedding' Python block differs from examples/python/tear.py")
        out = io.StringIO()
        cwd = os.getcwd()
        os.chdir(SOURCE)
        try:
            with contextlib.redirect_stdout(out):
                exec(compile(code, "README.md", "exec"), {"__name__": "__main__"})
        finally:
            os.chdir(cwd)
        text = out.getvalue()
        print(text)
        self.assertIn("moved: True", text)
        self.assertRegex(text, r"tears \d+ pieces \d+ hash [0-9a-f]+")
        self.assertRegex(text, r"InputError: mine\.json: sheet\.triangles")


if __name__ == "__main__":
    unittest.main()
