"""Two models in one plant: the belt drive's FMU (`rom export-fmu --kind fom`) stepped by FMPy,
and a fan duct with a damper written as a co-simulation block in Python.

The duct's air column takes the fan speed and answers with the torque the air puts on the fan
shaft beyond the configuration's fan law, which is the open duct's (docs/guide/export-fmu.md):
  flow          tau dq/dt = k_q a(t) n - q        (a first-order air column, q in m^3/s)
  extra torque  T = c n (q - k_q n)               (the shaft power follows the flow)
with n the fan speed in rpm and a(t) the damper's opening: closing it cuts the flow and, after
the air column's lag, unloads the fan. A toy duct, to show the coupling, not a duct model.
Both blocks exchange values every communication step (a Jacobi scheme, inputs held over the
step). Run: target/py-venv/bin/python examples/fmu/cosim.py [STOP_S]
"""

import os
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave

REPO = Path(__file__).resolve().parents[2]
ROM = Path(os.environ.get("BELTWIN_ROM", REPO / "target" / "release" / "rom"))
STEP_S = 1.0e-3  # communication step: the default drive's output interval


class Duct:
    """The duct with a damper closing from fully open to 60 % between 1.5 and 1.7 s."""

    tau_s = 0.2  # air column time constant
    k_q = 1.0e-3  # flow per fan rpm at full opening, m^3/s/rpm
    c = 1.0e-2  # torque per rpm and flow, N m / (rpm m^3/s)

    def __init__(self):
        self.q_m3_s = None

    def opening(self, t_s):
        return 1.0 - 0.4 * min(max((t_s - 1.5) / 0.2, 0.0), 1.0)

    def do_step(self, t_s, h_s, fan_rpm):
        a = self.opening(t_s)
        if self.q_m3_s is None:  # the air follows the fan from standstill
            self.q_m3_s = self.k_q * fan_rpm
        self.q_m3_s += h_s / self.tau_s * (self.k_q * a * fan_rpm - self.q_m3_s)
        return self.c * fan_rpm * (self.q_m3_s - self.k_q * fan_rpm)


def run(stop_s=3.0):
    """Rows (t, driver rpm, fan rpm, slip %, extra torque N m, duct flow m^3/s)."""
    work = Path(tempfile.mkdtemp(prefix="beltwin-cosim-"))
    fmu_path = work / "belt.fmu"
    subprocess.run([str(ROM), "export-fmu", "--kind", "fom", "--out", str(fmu_path)], check=True,
                   capture_output=True)
    with zipfile.ZipFile(fmu_path) as z:
        z.extractall(work / "belt")
    md = read_model_description(str(fmu_path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    belt = FMU2Slave(guid=md.guid, unzipDirectory=str(work / "belt"),
                     modelIdentifier=md.coSimulation.modelIdentifier, instanceName="belt")
    belt.instantiate()
    belt.setupExperiment(startTime=0.0)
    belt.enterInitializationMode()
    belt.exitInitializationMode()
    duct = Duct()
    outs = [vr["driver_speed_rpm"], vr["driven_speed_rpm"], vr["slip_pct"]]
    rows, torque, t = [], 0.0, 0.0
    for k in range(round(stop_s / STEP_S)):
        t = k * STEP_S
        belt.setReal([vr["extra_load_torque_nm"]], [torque])
        driver, fan, slip = belt.getReal(outs)
        torque = duct.do_step(t, STEP_S, fan)  # both blocks from the values at t
        belt.doStep(t, STEP_S)
        rows.append((t + STEP_S, *belt.getReal(outs), torque, duct.q_m3_s))
    belt.terminate()
    belt.freeInstance()
    return rows


if __name__ == "__main__":
    rows = run(float(sys.argv[1]) if len(sys.argv) > 1 else 3.0)
    print("time_s  driver_rpm  fan_rpm  slip_pct  extra_torque_nm  flow_m3_s")
    for r in rows[249::250]:
        print(f"{r[0]:6.3f}  {r[1]:10.2f}  {r[2]:7.2f}  {r[3]:8.4f}  {r[4]:15.3f}  {r[5]:9.4f}")
