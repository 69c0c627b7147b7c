"""The servo specification: one table that transmission, bridge, emulator and handle read.

Every number about the servo lives here: the model number on the bus, encoder ticks per
revolution, the joint-mode and multi-turn ranges, stall torque and no-load speed at the rated
voltage, mass, body outline and where the horn sits. Sources: ROBOTIS e-manual, MX-64 page
(Protocol 1.0 firmware, model number 310; specifications table: weight, "Dimensions (W x H x D)
40.2 x 61.1 x 41 mm"); horn part numbers and screw sizes from the Poppy project's assembly notes
(MX-64: horn HN05-N102, horn screws M2.5 x 4, centre screw M3 x 8, case screws M2.5 x 6).
The horn (28 mm across, 3 mm proud of the case, eight M2.5 holes on a 22 mm bolt circle, its
axis 13.0 mm from the top end of the case and centred in its width) is marked CAD below: it is
taken from public CAD models of the servo, not from a ROBOTIS drawing (a PDF not held here). They
agree: RhobanProject/MetabotStudio ``backends/dxl/models/mx64-arm.scad`` (horn d = 28, h = 3,
8 holes on r = 11) and ``mx64-values.scad`` (shaft 18 mm from the case's centre, 12.55 mm from
its top), an OpenSCAD ``dynamixel_mx_64.scad`` (8 bolts on r = 11) and a build123d model whose
numbers are "measured from the official ROBOTIS MX-64AT_AR STEP" (bolt circle 22 mm, axis 13.0
mm from the top). Check them against the servo in hand; the handle and the motor pulleys read
them from here only.
"""

from __future__ import annotations

import dataclasses
import math

__all__ = ["ServoSpec", "SERVOS", "servo_spec"]


@dataclasses.dataclass(frozen=True)
class ServoSpec:
    """Facts about one servo model (SI units, ticks for encoder counts).

    Attributes
    ----------
    name : str
        Model name as written in design files (``servo_model``).
    model_number : int
        Model Number register (address 0) of the Protocol 1.0 firmware.
    protocol : float
        Dynamixel protocol version the bridge speaks to it.
    ticks_per_rev : int
        Encoder ticks per motor revolution.
    joint_mode_max : int
        Largest Goal Position in joint mode (0 .. joint_mode_max).
    multi_turn_limit : int
        Largest |Goal Position| in multi-turn mode.
    max_torque_register : int
        Largest value of the Max Torque and Torque Limit registers (also the full scale of
        Present Load).
    speed_unit_rpm : float
        Moving Speed register unit (rpm per unit); 0 means "no speed control".
    max_speed_register : int
        Largest Moving Speed value in joint and multi-turn mode.
    temperature_limit : int
        Factory Temperature Limit (deg C); the bridge stops a move at this temperature.
    factory_id : int
        ID of a servo as shipped.
    factory_baud : int
        Bit rate of a servo as shipped (bit/s).
    stall_torque : float
        Stall torque at ``voltage`` (N m).
    no_load_speed : float
        No-load speed at ``voltage`` (rad/s).
    voltage : float
        Rated supply voltage the torque and speed refer to (V).
    mass : float
        Mass of the servo (kg).
    outline : tuple of 3 float
        Body width x height x depth (m), horn axis along the depth.
    horn_offset : float
        Distance of the horn axis from the centre of the case along its height (m); the axis
        lies in the middle of the width and leaves the case on the front face (depth).
    horn_diameter : float
        Outer diameter of the horn disc (m).
    horn_thickness : float
        How far the horn stands proud of the case's front face (m).
    horn_bolt_circle : float
        Diameter of the circle of threaded holes in the horn (m).
    horn_bolts : int
        Number of threaded holes on that circle.
    horn_bolt : str
        Thread and length of the horn screws.
    horn_part : str
        ROBOTIS part number of the horn.
    case_screw : str
        Thread and length of the screws that hold the case (and a saddle) together.
    """

    name: str
    model_number: int
    protocol: float
    ticks_per_rev: int
    joint_mode_max: int
    multi_turn_limit: int
    max_torque_register: int
    speed_unit_rpm: float
    max_speed_register: int
    temperature_limit: int
    factory_id: int
    factory_baud: int
    stall_torque: float
    no_load_speed: float
    voltage: float
    mass: float
    outline: tuple[float, float, float]
    horn_offset: float
    horn_diameter: float
    horn_thickness: float
    horn_bolt_circle: float
    horn_bolts: int
    horn_bolt: str
    horn_part: str
    case_screw: str

    @property
    def ticks_per_radian(self) -> float:
        """Encoder ticks per radian of motor rotation."""
        return self.ticks_per_rev / (2.0 * math.pi)


_MX64 = dict(
    model_number=310,
    protocol=1.0,
    ticks_per_rev=4096,
    joint_mode_max=4095,
    multi_turn_limit=28672,
    max_torque_register=1023,
    speed_unit_rpm=0.114,
    max_speed_register=1023,
    temperature_limit=80,
    factory_id=1,
    factory_baud=57_600,
    stall_torque=6.0,  # N m at 12 V, 4.1 A
    no_load_speed=63.0 * 2.0 * math.pi / 60.0,  # 63 rpm at 12 V
    voltage=12.0,
    outline=(0.0402, 0.0611, 0.041),  # W x H x D, e-manual specifications table
    horn_offset=0.0611 / 2 - 0.013,  # CAD: axis 13.0 mm from the top end of the case
    horn_diameter=0.028,  # CAD
    horn_thickness=0.003,  # CAD
    horn_bolt_circle=0.022,  # CAD
    horn_bolts=8,  # CAD
    horn_bolt="M2.5 x 4",  # Poppy assembly notes
    horn_part="HN05-N102",  # Poppy assembly notes
    case_screw="M2.5 x 6",  # Poppy assembly notes
)

#: Servo models the toolkit knows, by the name used in design files.
SERVOS: dict[str, ServoSpec] = {
    "MX-64T": ServoSpec(name="MX-64T", mass=0.126, **_MX64),
    "MX-64AT": ServoSpec(name="MX-64AT", mass=0.135, **_MX64),
}


def servo_spec(name: str) -> ServoSpec:
    """The specification of a servo model; ValueError naming ``servo_model`` if unknown."""
    try:
        return SERVOS[name]
    except KeyError:
        raise ValueError(f"servo_model: unknown model {name!r}; known: {sorted(SERVOS)}") from None
