"""Python bindings (issue 8). Run by ctest with PYTHONPATH=<build>/python, from the source directory."""
import contextlib
import io
import json
import os
import pathlib
import re
import signal
import tempfile
import threading
import time
import unittest

import numpy as np

import papertear

SOURCE = pathlib.Path(os.environ.get("PAPERTEAR_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
SCENARIO = str(SOURCE / "scenarios" / "start-inward.json")


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
        sc.fps = -1.0
        with self.assertRaises(papertear.InputError):
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
        sc.relaxation = "everywhere"
        with self.assertRaises(papertear.InputError):
            sc.validate()
        # The settings of `papertear --set`, written into the file's JSON before it is read.
        sc = papertear.load_scenario(SCENARIO, ["sim.relaxation=patch", "sim.relaxation_radius=0.04"])
        self.assertEqual((sc.relaxation, sc.relaxation_radius), ("patch", 0.04))
        with self.assertRaises(papertear.InputError):
            papertear.load_scenario(SCENARIO, ["sim.relaxation_radius=-1"])

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
        self.assertEqual(set(t), {"id", "parent", "kind", "frame", "uv", "tips", "detail", "reached_boundary"})
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
                frames_seen.add(sim.frame)
                tears, x, res = sim.tears, sim.positions, sim.result()
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
