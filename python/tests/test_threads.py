"""The GIL is released while the pipeline runs; extractors shared by threads
or one per thread give the results of a single thread."""

import sys
import threading

import lms_features as lf
import numpy as np

from conftest import log


def frames_of(name, count):
    frames = []
    for frame in lf.read_log(log(name)):
        frames.append(frame.ranges)
        if len(frames) == count:
            return frames
    return frames


def digest(f):
    return (f.lines.tobytes(), f.corners.tobytes(), f.segments.tobytes(), f.edges.tobytes(), tuple(f.stats.values()))


def test_run_releases_the_gil():
    """With a switch interval of an hour, a thread holding the GIL keeps it
    until it blocks or releases it. The main thread waits for the worker
    to start its runs; it gets the GIL back before the worker has finished
    them only if ``run`` releases it (no timing involved)."""
    ranges = frames_of("csail", 1)[0]
    ex = lf.Extractor(lf.Params(iterations=200))
    runs, done = 20, []
    started = threading.Event()

    def worker():
        started.set()
        for _ in range(runs):
            ex.run(ranges)
            done.append(1)

    old = sys.getswitchinterval()
    sys.setswitchinterval(3600)
    try:
        t = threading.Thread(target=worker)
        t.start()
        started.wait()
        seen = len(done)
    finally:
        sys.setswitchinterval(old)
    t.join()
    assert len(done) == runs
    assert seen < runs, "the main thread ran only after all runs: the GIL was held"


def test_threads_give_the_single_threads_results():
    frames = frames_of("csail", 60)
    params = lf.Params(sigma=0.01)
    want = [digest(lf.Extractor(params).run(r)) for r in frames]
    shared = lf.Extractor(params)
    results = {}

    def work(key, ex):
        results[key] = [digest(ex.run(r)) for r in frames]

    threads = [threading.Thread(target=work, args=(("own", i), lf.Extractor(params))) for i in range(3)]
    threads += [threading.Thread(target=work, args=(("shared", i), shared)) for i in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(results) == 6
    for key, got in results.items():
        assert got == want, key


def test_input_arrays_are_left_alone():
    ranges = frames_of("intel", 1)[0]
    before = ranges.copy()
    ranges.setflags(write=False)  # read in place: a read-only array is fine
    lf.Extractor().run(ranges, resolution_deg=1)
    assert np.array_equal(ranges, before)


def test_the_iterators_work_from_any_thread():
    path = log("csail")
    frames, records = lf.read_log(path), lf.extract_log(path)
    got = {}

    def work():
        got["frame"], got["record"] = next(frames), next(records)

    t = threading.Thread(target=work)
    t.start()
    t.join()
    assert (got["frame"].index, got["record"]["frame"]) == (0, 0)
    assert (next(frames).index, next(records)["frame"]) == (1, 1)


def test_a_dropped_iterator_ends_its_reader_thread():
    import gc
    import os
    import time

    tasks = "/proc/self/task"
    if not os.path.isdir(tasks):
        return  # threads are seen through Linux's /proc only

    def readers():
        names = []
        for t in os.listdir(tasks):
            try:
                with open(f"{tasks}/{t}/comm") as comm:
                    names.append(comm.read().strip())
            except OSError:
                pass  # the thread ended meanwhile
        return sum(name.startswith("lms_features") for name in names)

    live = [lf.read_log(log("csail")), lf.extract_log(log("csail"), lf.Params())]
    assert readers() >= 2
    for _ in range(20):
        next(lf.read_log(log("csail")))
        next(lf.extract_log(log("csail"), lf.Params()))
    del live
    gc.collect()
    deadline = time.monotonic() + 10
    while readers() and time.monotonic() < deadline:
        time.sleep(0.01)
    assert readers() == 0
