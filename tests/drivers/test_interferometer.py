"""Modbus interferometer controller: codec vectors, status decoding, and the
trigger handshake against the pymodbus-server emulator over loopback TCP."""

from __future__ import annotations

import struct

import pytest

from drivers.errors import ConnectionLost, DeviceError
from drivers.interferometer import InterferometerController, load_register_map
from drivers.interferometer.codec import decode_status, decode_value, encode_value
from mocks.interferometer import InterferometerEmulator, ModbusServerThread
from mocks.world import Noise, World


def test_float32_word_orders_match_protocols_md() -> None:
    # protocols.md 2.4: 123.456 = 0x42F6E979 -> ABCD [0x42F6, 0xE979]; CDAB [0xE979, 0x42F6]
    assert encode_value(123.456, "FLOAT32", "ABCD") == [0x42F6, 0xE979]
    assert encode_value(123.456, "FLOAT32", "CDAB") == [0xE979, 0x42F6]
    assert decode_value([0x3FC0, 0x0000], "FLOAT32") == 1.5
    assert decode_value([0xC010, 0x0000], "FLOAT32") == -2.25


@pytest.mark.parametrize("word_order", ["ABCD", "CDAB"])
def test_float64_holds_nanometres_over_a_metre(word_order: str) -> None:
    value = 1234.567891  # mm: 1.234567891 m to the nanometre
    raw = struct.pack(">d", value)
    words = [int.from_bytes(raw[i : i + 2], "big") for i in range(0, 8, 2)]
    if word_order == "CDAB":
        words.reverse()
    assert decode_value(words, "FLOAT64", word_order) == value
    assert encode_value(value, "FLOAT64", word_order) == words


def test_status_word_decoding() -> None:
    regmap = load_register_map()
    st = decode_status(0b10101, 7, 0, regmap)
    assert (st.ready, st.busy, st.data_valid, st.error, st.beam_ok) == (True, False, True, False, True)
    st = decode_status(0b01001, 8, 1, regmap)
    assert st.error and not st.beam_ok and st.error_code == 1 and "beam interrupted" in st.error_text


@pytest.fixture(params=["ABCD", "CDAB"])
def controller(request: pytest.FixtureRequest):
    world = World(noise=Noise.off(), seed=3)
    emu = InterferometerEmulator(world, word_order=request.param, measure_time_s=0.01)
    server = ModbusServerThread(emu.device())
    ctl = InterferometerController.from_url(server.url, word_order=request.param)
    yield world, ctl
    ctl.close()
    server.stop()


def test_trigger_handshake_returns_the_world_pose(controller) -> None:
    world, ctl = controller
    world.place_block(0)
    st = ctl.zero()
    assert st.ready and not st.busy and not st.error
    world.place_block(4)
    truth = world.capture()
    r = ctl.trigger_and_read()
    assert r.ok and r.sequence == st.sequence + 1
    assert r.position_mm == truth.position_mm  # FLOAT64: exact
    for name in ("stry_um", "strz_um", "pitch_urad", "yaw_urad", "roll_urad"):
        expected = struct.unpack(">f", struct.pack(">f", getattr(truth, name)))[0]  # FLOAT32 rounding
        assert getattr(r, name) == expected
    assert 15 < r.air_temp_c < 25 and 900 < r.air_pressure_hpa < 1100


def test_beam_loss_is_a_device_error_and_clears(controller) -> None:
    world, ctl = controller
    ctl.zero()
    world.beam_blocked = True
    with pytest.raises(DeviceError) as info:
        ctl.trigger_and_read()
    assert info.value.code == 1 and "beam interrupted" in info.value.text
    world.beam_blocked = False
    ctl.clear_error()
    assert ctl.trigger_and_read().ok


def test_read_and_describe_have_the_same_keys(controller) -> None:
    _, ctl = controller
    ctl.zero()
    reading, schema = ctl.read(), ctl.describe()
    assert reading.keys() == schema.keys()
    assert schema["position_mm"]["units"] == "mm" and schema["pitch_urad"]["units"] == "urad"


def test_unreachable_controller_is_connection_lost(refused_port: int) -> None:
    with pytest.raises(ConnectionLost, match="cannot connect"):
        InterferometerController.from_url(f"modbus-tcp://127.0.0.1:{refused_port}", timeout_s=0.3)


def test_bad_controller_url() -> None:
    with pytest.raises(ValueError, match="modbus-tcp://"):
        InterferometerController.from_url("tcp://1.2.3.4")
