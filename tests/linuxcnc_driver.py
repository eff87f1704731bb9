#!/usr/bin/python3
"""The headless "display" of the LinuxCNC check (tests/linuxcnc_sim.py): run by LinuxCNC's launcher
(``[DISPLAY] DISPLAY = ./linuxcnc_driver.py``) with the system ``/usr/bin/python3``, whose ``linuxcnc``
and ``hal`` modules come with the linuxcnc-uspace package (the project's venv does not have them).

Reads ``plan.json`` next to the INI (``{"joints": N, "stops": [x, ...], "out": "stops.json"}``), homes
every joint, then moves all joints together with MDI ``G53 G0`` to each stop in turn and, once the
motion and the backlash filter have come to rest, records the joints' HAL pins (machine units):
``pos-cmd``, ``motor-pos-cmd``, ``backlash-corr`` (the table's value), ``backlash-filt`` (what is
applied: motor-pos-cmd = pos-cmd + backlash-filt + motor-offset), ``backlash-vel``, ``motor-offset``.
The record file is rewritten (flushed, then renamed) after every stop.  When this script exits, the
launcher shuts LinuxCNC down; a failure exits non-zero with the reason on stderr.
"""

import json
import os
import sys
import time

import hal
import linuxcnc

PINS = ("pos-cmd", "motor-pos-cmd", "backlash-corr", "backlash-filt", "backlash-vel", "motor-offset")
AXES = "XYZUVW"  # linear axes, one joint each


def main() -> int:
    here = os.path.dirname(os.path.abspath(__file__))
    with open(os.path.join(here, "plan.json"), encoding="utf-8") as f:
        plan = json.load(f)
    joints, stops, out = int(plan["joints"]), [float(x) for x in plan["stops"]], os.path.join(here, plan["out"])
    with open(os.path.join(here, "driver.pid"), "w", encoding="utf-8") as f:
        f.write(str(os.getpid()))  # for the harness to end this run (the launcher then shuts LinuxCNC down)
    cmd, stat = linuxcnc.command(), linuxcnc.stat()
    probe = hal.component("guideway_probe")  # hal.get_value needs a component of this process
    probe.ready()

    def wait_for(what, cond, timeout_s=20.0):
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            stat.poll()
            if cond():
                return
            time.sleep(0.005)
        raise RuntimeError(f"timed out waiting for {what}")

    def pins(j):
        return {p: float(hal.get_value(f"joint.{j}.{p}")) for p in PINS}

    cmd.state(linuxcnc.STATE_ESTOP_RESET)
    wait_for("estop reset", lambda: stat.task_state == linuxcnc.STATE_ESTOP_RESET)
    cmd.state(linuxcnc.STATE_ON)
    wait_for("machine on", lambda: stat.task_state == linuxcnc.STATE_ON)
    cmd.mode(linuxcnc.MODE_MANUAL)
    cmd.wait_complete()
    cmd.home(-1)  # HOME_SEARCH_VEL = 0: every joint is homed where it stands, without motion
    cmd.wait_complete()
    wait_for("homing", lambda: all(stat.homed[:joints]))
    cmd.mode(linuxcnc.MODE_MDI)
    cmd.wait_complete()
    records = []
    for x in stops:
        cmd.mdi("G53 G0 " + " ".join(f"{AXES[j]}{x:.6f}" for j in range(joints)))
        if cmd.wait_complete(60.0) == -1:
            raise RuntimeError(f"the move to {x} did not complete")
        wait_for(f"the stop at {x}", lambda: stat.state == linuxcnc.RCS_DONE and stat.inpos)
        # at rest: the backlash filter has stopped too (its velocity 0, the same value twice)
        end = time.monotonic() + 10.0
        prev = None
        while True:
            now = [pins(j) for j in range(joints)]
            if prev == now and all(p["backlash-vel"] == 0.0 for p in now):
                break
            if time.monotonic() > end:
                raise RuntimeError(f"the joints did not come to rest at {x}")
            prev = now
            time.sleep(0.01)
        records.append({"commanded": x, "joints": now})
        tmp = out + ".tmp"
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump(records, f, indent=1)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, out)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except Exception as exc:  # the launcher shows our stderr; the test reads the exit and the record
        print(f"linuxcnc_driver: {type(exc).__name__}: {exc}", file=sys.stderr)
        sys.exit(3)
