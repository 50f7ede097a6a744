#!/usr/bin/env python3
"""Golden byte vectors for the auger serial protocol, written independently of the C code.

The frame layouts below are transcribed from docs/protocol.md (the byte tables) and the CRC
from its description: CRC-16 with the reflected CCITT polynomial 0x8408, start 0xFFFF, no
final XOR, over LEN, TYPE and PAYLOAD, stored little-endian. Packing uses Python's struct.

    gen_vectors.py > tests/protocol/golden_vectors.txt   # regenerate
    gen_vectors.py --check tests/protocol/golden_vectors.txt  # what the test suite runs
    gen_vectors.py --corpus DIR   # one file per frame: the fuzzer's seed corpus

Line format: NAME TYPE field=value ... | hex bytes of the whole frame. Floats are written
as C99 hexadecimal floats of their float32 value, so both sides read them exactly.
"""
import os
import struct
import sys

START = b"\xA5\x5A"

# type code, then (field, struct code) in wire order: docs/protocol.md.
LAYOUTS = {
    "setpoint": (0x01, [("seq", "H"), ("omega_crpm", "h"), ("flags", "B")]),
    "config": (0x02, None),  # filled below, shared with config_report
    "request": (0x03, [("what", "B")]),
    "telemetry": (0x81, [("time_ms", "I"), ("seq_ack", "H"), ("omega_crpm", "h"),
                         ("omega_cmd_crpm", "h"), ("position_counts", "i"),
                         ("current_ma", "h"), ("voltage_mv", "H"), ("duty_x10000", "h"),
                         ("status", "H"), ("rx_errors", "H"), ("encoder_errors", "H")]),
    "identity": (0x82, [("module_id", "B"), ("protocol_version", "B"), ("fw_major", "B"),
                        ("fw_minor", "B"), ("fw_patch", "B"), ("reset_cause", "B"),
                        ("flags", "B")]),
    "config_report": (0x83, None),
    "fault": (0x84, [("time_ms", "I"), ("faults", "H"), ("status", "H"), ("current_ma", "h"),
                     ("voltage_mv", "H"), ("omega_crpm", "h"), ("omega_cmd_crpm", "h"),
                     ("duty_x10000", "h")]),
}
CONFIG_FIELDS = [("module_id", "B"), ("dir_sign", "b"), ("flags", "B"),
                 ("counts_per_rev_x100", "I"), ("kp", "f"), ("ki", "f"), ("kd", "f"),
                 ("omega_max_crpm", "H"), ("overcurrent_ma", "H"),
                 ("overcurrent_samples", "B"), ("undervoltage_mv", "H"),
                 ("undervoltage_hyst_mv", "H"), ("motor_rated_mv", "H"),
                 ("cmd_timeout_ms", "H"), ("foldback_ma", "H"), ("stall_current_ma", "H"),
                 ("stall_time_ms", "H"), ("telemetry_period_ms", "B")]
LAYOUTS["config"] = (0x02, CONFIG_FIELDS)
LAYOUTS["config_report"] = (0x83, CONFIG_FIELDS)


def crc16(data: bytes) -> int:
    """CRC-16/MCRF4XX, bit by bit, as the CRC catalogue defines it."""
    crc = 0xFFFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0x8408 if crc & 1 else crc >> 1
    return crc


def f32(x: float) -> float:
    """The float32 nearest to x, as a Python float (exact)."""
    return struct.unpack("<f", struct.pack("<f", x))[0]


def frame(kind: str, values: dict) -> bytes:
    type_code, fields = LAYOUTS[kind]
    assert set(values) == {f for f, _ in fields}, kind
    payload = b"".join(struct.pack("<" + code, values[name]) for name, code in fields)
    body = bytes([len(payload), type_code]) + payload
    return START + body + struct.pack("<H", crc16(body))


DEFAULT_CONFIG = dict(module_id=0, dir_sign=1, flags=0, counts_per_rev_x100=1771200,
                      kp=f32(0.5), ki=f32(0.0003), kd=f32(0.005), omega_max_crpm=3000,
                      overcurrent_ma=5200, overcurrent_samples=5, undervoltage_mv=16000,
                      undervoltage_hyst_mv=500, motor_rated_mv=12000, cmd_timeout_ms=250,
                      foldback_ma=4500, stall_current_ma=2000, stall_time_ms=100,
                      telemetry_period_ms=10)

VECTORS = [
    ("setpoint_zero", "setpoint", dict(seq=0, omega_crpm=0, flags=0)),
    ("setpoint_10rpm_enable", "setpoint", dict(seq=1, omega_crpm=1000, flags=0x01)),
    ("setpoint_clear_faults", "setpoint", dict(seq=513, omega_crpm=-1234, flags=0x03)),
    ("setpoint_plus_300rpm", "setpoint", dict(seq=65534, omega_crpm=30000, flags=0x01)),
    ("setpoint_minus_300rpm", "setpoint", dict(seq=7, omega_crpm=-30000, flags=0x01)),
    ("setpoint_limits_high", "setpoint", dict(seq=65535, omega_crpm=32767, flags=0xFF)),
    ("setpoint_limits_low", "setpoint", dict(seq=0, omega_crpm=-32768, flags=0x00)),
    ("config_defaults", "config", DEFAULT_CONFIG),
    ("config_module3_reversed", "config",
     dict(DEFAULT_CONFIG, module_id=3, dir_sign=-1, kp=f32(1.25), ki=f32(0.02),
          kd=f32(0.0), counts_per_rev_x100=905328, foldback_ma=0, stall_time_ms=250,
          telemetry_period_ms=50)),
    ("config_limits", "config",
     dict(module_id=255, dir_sign=-128, flags=255, counts_per_rev_x100=0xFFFFFFFF,
          kp=f32(-3.4e38), ki=f32(1e-38), kd=f32(65504.0), omega_max_crpm=65535,
          overcurrent_ma=65535, overcurrent_samples=255, undervoltage_mv=65535,
          undervoltage_hyst_mv=65535, motor_rated_mv=65535, cmd_timeout_ms=65535,
          foldback_ma=65535, stall_current_ma=65535, stall_time_ms=65535,
          telemetry_period_ms=255)),
    ("config_zeros", "config", {name: 0.0 if code == "f" else 0 for name, code in CONFIG_FIELDS}),
    ("config_report_defaults", "config_report", dict(DEFAULT_CONFIG, module_id=2)),
    ("request_identity", "request", dict(what=0x82)),
    ("request_config", "request", dict(what=0x83)),
    ("telemetry_zero", "telemetry",
     dict(time_ms=0, seq_ack=0, omega_crpm=0, omega_cmd_crpm=0, position_counts=0,
          current_ma=0, voltage_mv=0, duty_x10000=0, status=0, rx_errors=0,
          encoder_errors=0)),
    ("telemetry_running", "telemetry",
     dict(time_ms=123450, seq_ack=4321, omega_crpm=998, omega_cmd_crpm=1000,
          position_counts=-1234567, current_ma=-850, voltage_mv=18432, duty_x10000=-4321,
          status=0x0003, rx_errors=2, encoder_errors=1)),
    ("telemetry_faulted", "telemetry",
     dict(time_ms=4000000000, seq_ack=65535, omega_crpm=0, omega_cmd_crpm=0,
          position_counts=2147483647, current_ma=5300, voltage_mv=15800, duty_x10000=0,
          status=0x0700, rx_errors=65535, encoder_errors=300)),
    ("telemetry_limits", "telemetry",
     dict(time_ms=0xFFFFFFFF, seq_ack=65535, omega_crpm=-32768, omega_cmd_crpm=32767,
          position_counts=-2147483648, current_ma=-32768, voltage_mv=65535,
          duty_x10000=10000, status=0xFFFF, rx_errors=65535, encoder_errors=65535)),
    ("identity_module0", "identity",
     dict(module_id=0, protocol_version=2, fw_major=0, fw_minor=2, fw_patch=0,
          reset_cause=0x01, flags=0x00)),
    ("identity_old_settings_warm", "identity",
     dict(module_id=3, protocol_version=2, fw_major=0, fw_minor=2, fw_patch=0,
          reset_cause=0x10, flags=0x02)),
    ("identity_limits", "identity",
     dict(module_id=255, protocol_version=255, fw_major=255, fw_minor=255, fw_patch=255,
          reset_cause=0xFF, flags=0xFF)),
    ("fault_stall", "fault",
     dict(time_ms=61230, faults=0x2000, status=0x2002, current_ma=4480, voltage_mv=17840,
          omega_crpm=0, omega_cmd_crpm=1000, duty_x10000=3890)),
    ("fault_overcurrent_reverse", "fault",
     dict(time_ms=4000000000, faults=0x0200, status=0x0226, current_ma=-5310, voltage_mv=15012,
          omega_crpm=-2304, omega_cmd_crpm=-3000, duty_x10000=-8000)),
    ("fault_limits", "fault",
     dict(time_ms=0xFFFFFFFF, faults=0xFFFF, status=0xFFFF, current_ma=-32768, voltage_mv=65535,
          omega_crpm=32767, omega_cmd_crpm=-32768, duty_x10000=-10000)),
]


def fmt_value(v) -> str:
    return v.hex() if isinstance(v, float) else str(v)


def render() -> str:
    lines = ["# auger protocol golden vectors (protocol version 2).",
             "# Generated by tests/protocol/gen_vectors.py; do not edit by hand.",
             "# NAME TYPE field=value ... | frame bytes (hex)"]
    for name, kind, values in VECTORS:
        _, fields = LAYOUTS[kind]
        kv = " ".join(f"{f}={fmt_value(values[f])}" for f, _ in fields)
        data = frame(kind, values)
        lines.append(f"{name} {kind} {kv} | {data.hex(' ').upper()}")
    return "\n".join(lines) + "\n"


def main(argv) -> int:
    assert crc16(b"123456789") == 0x6F91, "CRC-16/MCRF4XX check value"
    text = render()
    if len(argv) == 3 and argv[1] == "--check":
        path = argv[2]
        with open(path, encoding="utf-8") as f:
            stored = f.read()
        if stored != text:
            for i, (a, b) in enumerate(zip(stored.splitlines(), text.splitlines()), 1):
                if a != b:
                    print(f"{path}:{i}: stored vector differs from the generator:\n"
                          f"  stored:    {a}\n  generated: {b}", file=sys.stderr)
                    break
            else:
                print(f"{path}: line count differs from the generator", file=sys.stderr)
            return 1
        print(f"{path}: {len(VECTORS)} vectors match the independent generator")
        return 0
    if len(argv) == 3 and argv[1] == "--corpus":
        os.makedirs(argv[2], exist_ok=True)
        for name, kind, values in VECTORS:
            with open(os.path.join(argv[2], name), "wb") as f:
                f.write(frame(kind, values))
        return 0
    if len(argv) != 1:
        print(__doc__, file=sys.stderr)
        return 2
    sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
