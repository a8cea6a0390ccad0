"""Benchmark: the `dacm sensor` datasheet of sample B after import (no plots).

Prints one JSON object: import_s (the modules `dacm sensor` needs), first_s (the first
datasheet: the solver kernel's first call, cached compiled code), median_s (build_sensor,
datasheet and cross-axis, as `dacm sensor --no-plots` computes them; median of 7) and the
same for the image-fiber optics alone on the sensor's 241-point gap table (optics_ms), and
median_s in units of the reference computation (reference.py) measured in the same run,
with the last round's 0.5 s target in those units.

Run from the repository root: python -m tests.benchmarks.datasheet
"""

import json
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def main():
    t0 = time.perf_counter()
    import numpy as np

    from geometry.params import preset
    from sensor.readout.datasheet import cross_axis, datasheet
    from sensor.readout.optics import OpticsSetup, output_voltage
    from sensor.readout.sensor_model import GAP_TABLE_POINTS, build_sensor
    import_s = time.perf_counter() - t0
    design = preset("sample-b")

    def sheet():
        sensor = build_sensor(design)
        return datasheet(sensor, material=design.material.name), cross_axis(design, sensor.input_travel_mm)

    t0 = time.perf_counter()
    sheet()
    first_s = time.perf_counter() - t0
    times = []
    for _ in range(7):
        t0 = time.perf_counter()
        sheet()
        times.append(time.perf_counter() - t0)
    gaps = np.linspace(0.0, 3.0, GAP_TABLE_POINTS)
    optics = []
    for _ in range(7):
        t0 = time.perf_counter()
        output_voltage(gaps, OpticsSetup())
        optics.append(time.perf_counter() - t0)
    from tests.benchmarks.reference import in_reference, reference_s, target

    ref = reference_s()
    print(json.dumps({"import_s": round(import_s, 3), "first_s": round(first_s, 3),
                      "median_s": round(float(np.median(times)), 4),
                      "optics_ms": round(float(np.median(optics)) * 1e3, 3), "reference_s": round(ref, 4),
                      "median_in_reference": in_reference(float(np.median(times)), ref),
                      "target_median_in_reference": target("datasheet_median"), "load_average": os.getloadavg()}))


if __name__ == "__main__":
    main()
