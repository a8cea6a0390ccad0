"""Print the model against thesis Table 6 (as-cut specimens, the drawn hinge length, elastic
hinge roots fitted to the continuum FE). Run: python examples/table6.py"""

from sensor.mechanics.hysteresis import DEFAULT_LAW
from geometry.params import preset
from sensor.mechanics.table6 import calibrate_hinge_length, table6_comparison


def pct(model, thesis):
    return f"{100 * (model / thesis - 1):+.0f} %"


def main():
    print(f"hinge length: {preset('basis').hinge_length_mm:.2f} mm as drawn (fitting it to the basis' "
          f"measured sensitivity would give {calibrate_hinge_length():.3f} mm)")
    print(f"hysteresis law: H = {DEFAULT_LAW.h_per_mJ:.4f} x SE (calibrated on the basis specimen)")
    print("| specimen | A model / thesis | sensitivity mm/N model / thesis / measured | SE mJ model / thesis "
          "| H predicted / measured | quality mm/N predicted / measured |")
    print("|---|---|---|---|---|---|")
    for r in table6_comparison():
        print(f"| {r.specimen} | {r.amplification:.2f} / {r.amplification_thesis:.2f} ({pct(r.amplification, r.amplification_thesis)}) "
              f"| {r.sensitivity_mm_per_N:.3f} / {r.sensitivity_thesis:.3f} ({pct(r.sensitivity_mm_per_N, r.sensitivity_thesis)}) / {r.sensitivity_measured:.3f} "
              f"| {r.strain_energy_mJ:.3f} / {r.strain_energy_thesis:.3f} ({pct(r.strain_energy_mJ, r.strain_energy_thesis)}) "
              f"| {r.hysteresis_predicted:.3f} / {r.hysteresis_measured:.3f} "
              f"| {r.quality_predicted:.2f} / {r.quality_measured:.2f} |")


if __name__ == "__main__":
    main()
