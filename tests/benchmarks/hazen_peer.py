"""The peer of the SNR benchmark: hazen's SNR task on a DICOM pair, files to SNR, run by
the interpreter
of the venv hazen is installed in (hazen pins numpy < 2.4, so it has its own venv: see
the Makefile's HAZEN_VENV). It imports nothing of dacm.

Two things are timed: ``pair`` (the task reads both files and computes the subtraction SNR
of the pair: what dacm's pair measurement does) and ``task`` (the whole SNR task, which
also computes the smoothing SNR of each image).

Protocol: started with the two DICOM paths; each line read from stdin is a count N, and
the answer is one JSON line: N wall and CPU (thread) times (s) of each. An empty line or
end of input ends it.
"""

import json
import sys
import time

from hazenlib.tasks.snr import SNR


def task(paths: list[str]) -> dict:
    result = SNR(input_data=paths, report=False).run()
    return {f"{m.subtype}/{m.type}/{m.description or 'pair'}": m.value for m in result.measurements}


def pair(paths: list[str]) -> float:
    t = SNR(input_data=paths, report=False)
    return t.snr_by_subtraction(t.dcm_list[0], t.dcm_list[1], t.measured_slice_width)[0]


def timed(fn, paths, n: int) -> tuple[list[float], list[float]]:
    """Wall and CPU (thread) times (s) of n calls."""
    wall, cpu = [], []
    for _ in range(n):
        t0, c0 = time.perf_counter(), time.thread_time()
        fn(paths)
        cpu.append(time.thread_time() - c0)
        wall.append(time.perf_counter() - t0)
    return wall, cpu


def main() -> None:
    import hazenlib

    paths = sys.argv[1:3]
    snr = task(paths)  # warm-up: imports and caches
    print(json.dumps({"version": getattr(hazenlib, "__version__", "unknown"), "snr": snr}), flush=True)
    for line in sys.stdin:
        if not line.strip():
            break
        n = int(line)
        (pair_s, pair_cpu_s), (task_s, task_cpu_s) = timed(pair, paths, n), timed(task, paths, n)
        print(json.dumps({"pair_s": pair_s, "pair_cpu_s": pair_cpu_s, "task_s": task_s, "task_cpu_s": task_cpu_s}),
              flush=True)


if __name__ == "__main__":
    main()
