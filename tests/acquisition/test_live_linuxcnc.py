"""The LinuxCNC files of live compensation checked against the formats' documented rules, written here
from LinuxCNC's own documents (github:LinuxCNC/linuxcnc): docs/src/drivers/mb2hal_HOWTO.ini (sections,
required keys, function codes, pin naming of VERSION=1.1), docs/src/motion/external-offsets.adoc
(OFFSET_AV_RATIO 0 … 0.9, the axis.L.eoffset-* pins) and the pins of the HAL components used (comp.comp,
sum2.comp, mux2.comp, bitslice.comp, watchdog(9), conv_*)."""

from __future__ import annotations

import configparser
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

MB_TX_CODES = {"fnct_01_read_coils", "fnct_02_read_discrete_inputs", "fnct_03_read_holding_registers",
               "fnct_04_read_input_registers", "fnct_05_write_single_coil", "fnct_06_write_single_register",
               "fnct_15_write_multiple_coils", "fnct_16_write_multiple_registers"}
INIT_KEYS = {"INIT_DEBUG", "VERSION", "HAL_MODULE_NAME", "SLOWDOWN", "TOTAL_TRANSACTIONS"}
TX_KEYS = {"LINK_TYPE", "TCP_IP", "TCP_PORT", "SERIAL_PORT", "SERIAL_BAUD", "SERIAL_BITS", "SERIAL_PARITY",
           "SERIAL_STOP", "SERIAL_DELAY_MS", "MB_SLAVE_ID", "FIRST_ELEMENT", "NELEMENTS", "PIN_NAMES",
           "MB_TX_CODE", "MB_RESPONSE_TIMEOUT_MS", "MB_BYTE_TIMEOUT_MS", "HAL_TX_NAME", "MAX_UPDATE_RATE", "DEBUG"}
# pins of the HAL components (their .comp files / man pages): name -> pins of one instance
COMPONENT_PINS = {
    "sum2": {"in0", "in1", "gain0", "gain1", "offset", "out"},
    "comp": {"in0", "in1", "hyst", "out", "equal"},
    "mux2": {"in0", "in1", "sel", "out"},
    "conv_float_s32": {"in", "out", "clamp", "out-of-range"},
    "conv_s32_u32": {"in", "out", "clamp", "out-of-range"},
    "bitslice": {"in"} | {f"out-{i:02d}" for i in range(32)},
    "and2": {"in0", "in1", "out"},
}
OUT_PINS = {"sum2": {"out"}, "comp": {"out", "equal"}, "mux2": {"out"}, "conv_float_s32": {"out"},
            "conv_s32_u32": {"out"}, "bitslice": {f"out-{i:02d}" for i in range(32)}, "and2": {"out"}}


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("lc")
    res = subprocess.run([sys.executable, "-m", "tui.cli", "compensate", "linuxcnc-config", "--axis", "C",
                          "--server", "192.168.1.20:1502", "--timeout-ms", "400", "--out", str(out)], cwd=ROOT,
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr
    return out


def mb2hal(path: Path) -> configparser.ConfigParser:
    cp = configparser.ConfigParser(comment_prefixes=("#",), interpolation=None)
    cp.optionxform = str  # keys are upper case
    cp.read(path)
    return cp


def test_mb2hal_config_follows_the_howto(files: Path) -> None:
    cp = mb2hal(files / "guideway-live-mb2hal.ini")
    init = cp["MB2HAL_INIT"]
    assert set(init) <= INIT_KEYS
    total = int(init["TOTAL_TRANSACTIONS"])
    tx = [s for s in cp.sections() if s != "MB2HAL_INIT"]
    assert tx == [f"TRANSACTION_{i:02d}" for i in range(total)]  # one section each, from 00, sequential
    first = cp[tx[0]]
    assert set(first) <= TX_KEYS
    assert first["LINK_TYPE"] == "tcp" and re.fullmatch(r"\d+\.\d+\.\d+\.\d+", first["TCP_IP"])
    assert first["TCP_PORT"] == "1502" and first["MB_SLAVE_ID"].isdigit()
    assert first["FIRST_ELEMENT"] == "8"  # decimal integer: register 8 (enable) of the interface
    assert ("NELEMENTS" in first) != ("PIN_NAMES" in first)  # it is an error to give both
    assert not re.search(r"\s", first["PIN_NAMES"])
    assert first["MB_TX_CODE"] in MB_TX_CODES
    assert len(first["HAL_TX_NAME"]) <= 28
    assert int(first["MB_RESPONSE_TIMEOUT_MS"]) > 0 and float(first["MAX_UPDATE_RATE"]) >= 0
    assert init["VERSION"] == "1.1"  # the pin names the HAL file uses (mb2hal.TX.NAME.int / .float)


def test_hal_file_wires_existing_pins(files: Path) -> None:
    cp = mb2hal(files / "guideway-live-mb2hal.ini")
    tx = cp["TRANSACTION_00"]
    # fnct_03 creates mb2hal.<HAL_TX_NAME>.<name>.float and .int (outputs) per PIN_NAMES entry, in order
    mb_pins = {f"mb2hal.{tx['HAL_TX_NAME']}.{n}.{t}" for n in tx["PIN_NAMES"].split(",") for t in ("float", "int")}
    names = tx["PIN_NAMES"].split(",")
    assert names[:4] == ["enable", "heartbeat", "echo", "counts"]  # registers 8, 9, 10, 11
    instances: dict[str, str] = {}
    functions: set[str] = set()
    watchdog_inputs = 0
    pins: set[str] = set(mb_pins) | {f"axis.c.eoffset-{p}" for p in ("enable", "scale", "counts", "clear")}
    writers: set[str] = set(mb_pins)
    lines = [ln for ln in (files / "guideway-live.hal").read_text().splitlines() if ln and not ln.startswith("#")]
    nets: list[tuple[str, list[str]]] = []
    for line in lines:
        words = line.split()
        if words[0] == "loadusr":
            assert words[1] == "-W" and words[2] == "mb2hal" and words[3] == "config=guideway-live-mb2hal.ini"
        elif words[0] == "loadrt":
            comp, opts = words[1], dict(w.split("=", 1) for w in words[2:])
            if comp == "watchdog":
                watchdog_inputs = int(opts["num_inputs"])
                assert 1 <= watchdog_inputs <= 32
                pins |= {"watchdog.enable-in", "watchdog.ok-out"} | {
                    f"watchdog.{p}-{i}" for i in range(watchdog_inputs) for p in ("input", "timeout")}
                writers.add("watchdog.ok-out")
                continue
            for inst in opts["names"].split(","):
                assert inst not in instances
                instances[inst] = comp
                pins |= {f"{inst}.{p}" for p in COMPONENT_PINS[comp]}
                writers |= {f"{inst}.{p}" for p in OUT_PINS[comp]}
            if comp == "bitslice":
                assert len(opts["personality"].split(",")) == len(opts["names"].split(","))
        elif words[0] == "addf":
            assert words[2] == "servo-thread"
            functions.add(words[1])
        elif words[0] == "setp":
            assert len(words) == 3 and words[1] in pins, line
            float(words[2])
        elif words[0] == "net":
            assert words[2] in pins, line
            assert "=>" in words or len(words) == 3
            nets.append((words[1], [w for w in words[2:] if w != "=>"]))
        else:
            pytest.fail(f"not a HAL command: {line}")
    assert set(instances) | {"watchdog.process", "watchdog.set-timeouts"} == functions  # every function runs
    for signal, members in nets:
        assert all(m in pins for m in members), (signal, members)
        assert sum(m in writers for m in members) == 1, (signal, members)  # exactly one writer per signal
    text = "\n".join(lines)
    # one count of register 11 is 0.01 arcsec on a rotary axis, in degrees
    scale = float(re.search(r"setp axis\.c\.eoffset-scale (\S+)", text).group(1))  # type: ignore[union-attr]
    assert scale == pytest.approx(0.01 / 3600.0, rel=1e-9)
    assert "setp watchdog.timeout-0 0.4" in text
    assert re.search(r"net \S+ \S+ => axis\.c\.eoffset-counts$", text, re.M)


def test_ini_lines(files: Path) -> None:
    cp = configparser.ConfigParser(interpolation=None)
    cp.optionxform = str
    cp.read(files / "guideway-live.ini")
    assert 0 < float(cp["AXIS_C"]["OFFSET_AV_RATIO"]) <= 0.9  # 0 would disable the external offset
    assert cp["HAL"]["HALFILE"] == "guideway-live.hal"


@pytest.mark.parametrize(("args", "fragment"), [
    (("--axis", "Q", "--server", "1.2.3.4"), "one axis letter"),
    (("--axis", "X", "--server", "machine.local"), "IPv4"),
    (("--axis", "X", "--server", "1.2.3.4", "--av-ratio", "0"), "OFFSET_AV_RATIO"),
])
def test_bad_options_are_one_line(tmp_path: Path, args: tuple[str, ...], fragment: str) -> None:
    res = subprocess.run([sys.executable, "-m", "tui.cli", "compensate", "linuxcnc-config", *args, "--out",
                          str(tmp_path / "o")], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert res.returncode == 2 and res.stderr.count("\n") == 1 and fragment in res.stderr, res.stderr
    assert not (tmp_path / "o").exists()


def test_component_path_hal(tmp_path: Path) -> None:
    res = subprocess.run([sys.executable, "-m", "tui.cli", "compensate", "linuxcnc-config", "--axis", "X",
                          "--server", "0.0.0.0:1502", "--via", "component", "--out", str(tmp_path)], cwd=ROOT,
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["guideway-live-component.hal", "guideway-live.ini"]
    lines = [ln for ln in (tmp_path / "guideway-live-component.hal").read_text().splitlines()
             if ln and not ln.startswith("#")]
    load = lines[0].split()
    assert load[:3] == ["loadusr", "-Wn", "guideway-live"]  # -Wn waits for the component of that name
    assert load[3:6] == ["python3", "-m", "drivers.live_compensation.linuxcnc_component"]
    # pins: the component's (its newpin calls) and motion's (axis.L.pos-cmd, motion.is-all-homed: outputs)
    component_in, component_out = {"guideway-live.pos-cmd", "guideway-live.homed"}, {"guideway-live.eoffset-counts"}
    motion_out, motion_in = {"axis.x.pos-cmd", "motion.is-all-homed"}, {"axis.x.eoffset-counts"}
    nets = [ln.split() for ln in lines if ln.startswith("net ")]
    assert len(nets) == 3
    for net in nets:
        src, dst = net[2], net[4]
        assert net[3] == "=>" and src in component_out | motion_out and dst in component_in | motion_in, net
    text = "\n".join(lines)
    assert "setp axis.x.eoffset-scale 0.0001" in text  # one count = 0.1 um = 1e-4 mm
    assert "setp axis.x.eoffset-enable 1" in text
