"""Dynamixel MX-64T/AT, Protocol 1.0 firmware (model number 310): control table and units.

Facts from the ROBOTIS e-manual (MX-64 page) and the DynamixelSDK sources. Positions are
4096 ticks per turn; joint mode spans one turn (0..4095, bounded by the CW/CCW angle
limits), multi-turn mode (CW = CCW = 4095) spans -28672..28672, two's complement on the bus.
"""

from __future__ import annotations

from handarm.servo import SERVOS

__all__ = [
    "MODEL_NUMBER",
    "MODEL_NUMBER_MX2",
    "TICKS_PER_REV",
    "MULTI_TURN_LIMIT",
    "ADDR",
    "EEPROM_END",
    "ERROR_BITS",
    "STOP_BITS",
    "MONITOR_ADDR",
    "MONITOR_SIZE",
    "BAUD_VALUES",
    "SDK_BAUDS",
    "SERVO_BAUD_REGISTER",
    "to_unsigned16",
    "from_unsigned16",
    "baud_register",
]

_SPEC = SERVOS["MX-64T"]  # the numbers live in the servo specification
MODEL_NUMBER = _SPEC.model_number  # MX-64 with Protocol 1.0 firmware
MODEL_NUMBER_MX2 = 311  # MX-64 with MX(2.0) firmware: a different control table
TICKS_PER_REV = _SPEC.ticks_per_rev
MULTI_TURN_LIMIT = _SPEC.multi_turn_limit  # |Goal Position| in multi-turn mode (7 turns)

#: Control-table addresses (Protocol 1.0 firmware), with their sizes in bytes.
ADDR = {
    "model_number": (0, 2),
    "firmware_version": (2, 1),
    "id": (3, 1),
    "baud_rate": (4, 1),
    "return_delay_time": (5, 1),
    "cw_angle_limit": (6, 2),
    "ccw_angle_limit": (8, 2),
    "temperature_limit": (11, 1),
    "min_voltage_limit": (12, 1),
    "max_voltage_limit": (13, 1),
    "max_torque": (14, 2),
    "status_return_level": (16, 1),
    "alarm_led": (17, 1),
    "shutdown": (18, 1),
    "multi_turn_offset": (20, 2),
    "resolution_divider": (22, 1),
    "torque_enable": (24, 1),
    "led": (25, 1),
    "d_gain": (26, 1),
    "i_gain": (27, 1),
    "p_gain": (28, 1),
    "goal_position": (30, 2),
    "moving_speed": (32, 2),
    "torque_limit": (34, 2),
    "present_position": (36, 2),
    "present_speed": (38, 2),
    "present_load": (40, 2),
    "present_voltage": (42, 1),
    "present_temperature": (43, 1),
    "moving": (46, 1),
    "lock": (47, 1),
}
EEPROM_END = 24
#: Present Load, Present Voltage and Present Temperature, read together during moves.
MONITOR_ADDR, MONITOR_SIZE = 40, 4

#: Error bits of a Protocol 1.0 status packet.
ERROR_BITS = {
    0x01: "input voltage",
    0x02: "angle limit",
    0x04: "overheating",
    0x08: "range",
    0x10: "checksum",
    0x20: "overload",
    0x40: "instruction",
}
#: Error bits that stop a move (the servo's Shutdown default, 36, uses the same two).
STOP_BITS = 0x04 | 0x20  # addresses below this persist across power cycles

#: Baud Rate register values of the MX-64's listed rates (its control table): what a servo
#: can be set to, by handarm or by another tool.
SERVO_BAUD_REGISTER = {
    1_000_000: 1,
    500_000: 3,
    400_000: 4,
    250_000: 7,
    200_000: 9,
    115_200: 16,
    57_600: 34,
    19_200: 103,
    9_600: 207,
    2_250_000: 250,
    2_500_000: 251,
    3_000_000: 252,
}

#: The rates the SDK's ``PortHandler.setBaudRate`` accepts (its ``getCFlagBaud``); it
#: returns False for any other, 200,000 bit/s among them. A test holds this against the
#: installed SDK.
SDK_BAUDS = frozenset(
    {9_600, 19_200, 38_400, 57_600, 115_200, 230_400, 460_800, 500_000, 576_000, 921_600,
     1_000_000, 1_152_000, 2_000_000, 2_500_000, 3_000_000, 3_500_000, 4_000_000}
)  # fmt: skip

#: Baud Rate register values of the rates the MX-64 and the SDK share: the only ones the
#: bus can open (a scan that tried 200,000 bit/s stopped there, on every port).
BAUD_VALUES = {b: v for b, v in SERVO_BAUD_REGISTER.items() if b in SDK_BAUDS}


def to_unsigned16(value: int) -> int:
    """Signed tick count to the 16-bit two's complement the bus carries."""
    return value & 0xFFFF


def from_unsigned16(value: int) -> int:
    """16-bit two's complement from the bus to a signed tick count."""
    return value - 0x10000 if value > 0x7FFF else value


def baud_register(baud: int) -> int:
    """Baud Rate register value for a bit rate; ValueError if the servo cannot do it."""
    if baud not in BAUD_VALUES:
        raise ValueError(
            f"baud_rate: {baud} is not a rate the MX-64 and the SDK share; "
            f"choose one of {sorted(BAUD_VALUES)}"
        )
    return BAUD_VALUES[baud]
