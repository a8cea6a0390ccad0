"""Print the model against thesis Table 6: the specimens as cut (Table 7 hinges, the 0.8 mm
jet's root fillets), the root rule fitted to the continuum FE, delrin's modulus calibrated on
the basis specimen, samples A and B predicted with nothing touched. Run: python examples/table6.py"""

from sensor.mechanics.hysteresis import DEFAULT_LAW
from geometry.params import preset
from sensor.mechanics.table6 import calibrate_modulus, table6_comparison


def pct(model, thesis):
    return f"{round(100 * (model / thesis - 1)):+d} %"  # an int: -0.04 % prints as +0 %


def main():
    d = preset("basis-as-cut")
    print(f"as cut, kerf {d.kerf_mm:g} mm; hinge length {d.hinge_length_mm:.2f} mm as drawn; delrin E "
          f"{d.material.E_MPa / 1000:.3f} GPa, calibrated on the basis specimen's measured sensitivity "
          f"(recomputed: {calibrate_modulus() / 1000:.3f} GPa)")
    print(f"hysteresis law: H = {DEFAULT_LAW.h_per_mJ:.4f} x SE (calibrated on the basis specimen)")
    print("| specimen | A model / thesis | sensitivity mm/N model / thesis / measured | SE mJ model / thesis / measured "
          "| H predicted / measured | quality mm/N predicted / measured |")
    print("|---|---|---|---|---|---|")
    for r in table6_comparison():
        print(f"| {r.specimen} | {r.amplification:.2f} / {r.amplification_thesis:.2f} ({pct(r.amplification, r.amplification_thesis)}) "
              f"| {r.sensitivity_mm_per_N:.3f} / {r.sensitivity_thesis:.3f} ({pct(r.sensitivity_mm_per_N, r.sensitivity_thesis)}) / {r.sensitivity_measured:.3f} ({pct(r.sensitivity_mm_per_N, r.sensitivity_measured)}) "
              f"| {r.strain_energy_mJ:.3f} / {r.strain_energy_thesis:.3f} ({pct(r.strain_energy_mJ, r.strain_energy_thesis)}) / {r.strain_energy_measured:.3f} ({pct(r.strain_energy_mJ, r.strain_energy_measured)}) "
              f"| {r.hysteresis_predicted:.3f} / {r.hysteresis_measured:.3f} ({pct(r.hysteresis_predicted, r.hysteresis_measured)}) "
              f"| {r.quality_predicted:.2f} / {r.quality_measured:.2f} |")


if __name__ == "__main__":
    main()
