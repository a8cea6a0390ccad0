"""Print the model against thesis Table 6 (as-cut specimens, hinge length calibrated on the
basis). Run: python examples/table6.py"""

from sensor.mechanics.hysteresis import DEFAULT_LAW
from sensor.mechanics.table6 import calibrate_hinge_length, table6_comparison


def pct(model, thesis):
    return f"{100 * (model / thesis - 1):+.0f} %"


def main():
    print(f"hinge length calibrated on the basis specimen: {calibrate_hinge_length():.3f} mm")
    print(f"hysteresis law: H = {DEFAULT_LAW.h_per_mJ:.4f} x SE (calibrated on the basis specimen)")
    print("| specimen | A model / thesis | sensitivity mm/N model / thesis | SE mJ model / thesis "
          "| H predicted / measured | quality mm/N predicted / measured |")
    print("|---|---|---|---|---|---|")
    for r in table6_comparison():
        print(f"| {r.specimen} | {r.amplification:.2f} / {r.amplification_thesis:.2f} ({pct(r.amplification, r.amplification_thesis)}) "
              f"| {r.sensitivity_mm_per_N:.3f} / {r.sensitivity_thesis:.3f} ({pct(r.sensitivity_mm_per_N, r.sensitivity_thesis)}) "
              f"| {r.strain_energy_mJ:.3f} / {r.strain_energy_thesis:.3f} ({pct(r.strain_energy_mJ, r.strain_energy_thesis)}) "
              f"| {r.hysteresis_predicted:.3f} / {r.hysteresis_measured:.3f} "
              f"| {r.quality_predicted:.2f} / {r.quality_measured:.2f} |")


if __name__ == "__main__":
    main()
