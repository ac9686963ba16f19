"""Objects standing on a floor (a connection of two surfaces): friction holds
them below the friction angle, they slide down beyond it to the floor's side
(or off a floor that says `slide_off: true`), and they fall over when the
floor's push would have to act beyond the edge of their base.

Tolerances: t to 1e-3 of the floor (0.4 mm on a 400 mm floor: the friction
term's smoothing lets a held object creep up to half a millimetre times
r/sqrt(1-r^2)); a topple distance to 1 mm (the statics is exact; the margin
covers the turn the solver chose for a square base)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from fabhal import api
from fabhal.meshes import mass_properties
from fabhal.solve import Topple
from tests.solve.test_physics import solve_text

RAMP = 400.0  # mm, the floor's width and length
BOTTLE_BASE = 77.0  # mm, SoapBottle's surface

BOTTLE_ON_RAMP = """\
environment ramp = Surface(width: 400, length: 400{extra}) at (0, 0, 0) rot ({rot})
soap = SoapBottle()
connect soap.surface -- ramp
target soap.rod at (0, 0, 80)
"""

POST_ON_RAMP = """\
part Post "A tall post on a square foot." {{
  material wood
  rod rod(radius: 10, length: 300) at (0, 0, 150)
  surface foot(width: 40, length: 40)
}}
environment ramp = Surface(width: 400, length: 400) at (0, 0, 0) rot ({slope}, 0, 0)
post = Post()
connect post.foot -- ramp
target post.rod at (0, 0, 150)
"""


def where_on_ramp(result: api.SolveResult) -> tuple[float, float]:
    solution = result.solution
    assert solution is not None
    (standing,) = solution.model.standing
    t1, t2 = standing.slide
    return float(solution.x[t1]), float(solution.x[t2])


def test_friction_holds_a_bottle_on_a_gentle_slope(tmp_path: Path) -> None:
    """Slope 10 degrees: the pull along the floor is tan 10 = 0.18 of the push
    into it, under mu = 0.3: the bottle stays in the middle where it was stood
    (t1 = t2 = 0.5), and the floor carries its whole weight (723 g: 7.09 N)."""
    result = solve_text(tmp_path, BOTTLE_ON_RAMP.format(extra="", rot="10, 0, 0"))
    assert result.status == "solved"
    assert np.allclose(where_on_ramp(result), (0.5, 0.5), atol=1e-3)
    forces = result.solution.forces
    assert forces is not None
    assert abs(np.linalg.norm(forces[0]) - 0.723096 * 9.81) < 0.01


def test_a_bottle_slides_down_a_steep_floor_to_its_side(tmp_path: Path) -> None:
    """Slope 20 degrees: tan 20 = 0.36 > 0.3, the bottle slides down the ramp
    (rot (20, 0, 0) tilts the floor about x: its t1 runs downhill, towards
    world -y) until its 77 mm base meets the ramp's side: its centre is then
    38.5 mm from the border, t1 = 1 - 77 / (2 x 400) = 0.90375, and t2 stays
    0.5. Leaning on the side it stands, at rest: solved."""
    result = solve_text(tmp_path, BOTTLE_ON_RAMP.format(extra="", rot="20, 0, 0"))
    assert result.status == "solved"
    expected = 1.0 - BOTTLE_BASE / (2.0 * RAMP)
    assert np.allclose(where_on_ramp(result), (expected, 0.5), atol=1e-3)


def test_friction_on_a_floor_is_the_same_in_every_direction(tmp_path: Path) -> None:
    """The ramp sloping 20 degrees along its diagonal (tilted about x after a
    45-degree turn in its own plane). Coulomb friction resists the slide, not
    each of the floor's axes apart: tan 20 = 0.36 > 0.3, so the bottle slides
    down the diagonal into the corner (t1 = t2 = 0.90375). Friction taken per
    axis would see 0.36 / sqrt 2 = 0.26 < 0.3 on each and wrongly hold it."""
    angles = (
        Rotation.from_euler("x", 20, degrees=True) * Rotation.from_euler("z", 45, degrees=True)
    ).as_euler("xyz", degrees=True)
    rot = ", ".join(f"{a:.6f}" for a in angles)
    result = solve_text(tmp_path, BOTTLE_ON_RAMP.format(extra="", rot=rot))
    assert result.status == "solved"
    corner = 1.0 - BOTTLE_BASE / (2.0 * RAMP)
    offsets = np.abs(np.subtract(where_on_ramp(result), 0.5))  # the downhill corner, whichever it is
    assert np.allclose(offsets, corner - 0.5, atol=1e-3)


def test_a_bottle_slides_off_a_floor_that_has_no_side(tmp_path: Path) -> None:
    """The same 20-degree ramp with `slide_off: true` (a shelf, not a basket):
    at its border nothing holds the bottle, which slides off: E501 at the
    connection, falls_apart."""
    result = solve_text(tmp_path, BOTTLE_ON_RAMP.format(extra=", slide_off: true", rot="20, 0, 0"))
    assert result.status == "falls_apart"
    (fall,) = [d for d in result.diagnostics if d.code == "E501"]
    assert "`soap` slides off" in fall.message
    assert fall.span is not None and fall.span.line == 3


def post_height(result: api.SolveResult) -> float:
    solution = result.solution
    assert solution is not None
    spec = solution.model.parts[solution.model.part_index("post")].spec
    return mass_properties(spec).center_of_mass[2]  # above its foot (the part's origin)


def test_a_tall_post_stands_on_a_gentle_slope(tmp_path: Path) -> None:
    """Slope 5 degrees: the floor's push acts h tan 5 downhill of the foot's
    middle, h the post's centre of mass above its foot (about 145 mm: 12.7
    mm), inside the 40 mm foot's 20 mm half width: it stands."""
    result = solve_text(tmp_path, POST_ON_RAMP.format(slope=5))
    assert post_height(result) * np.tan(np.radians(5)) < 20.0
    assert result.status == "solved"


def test_a_tall_post_falls_over_on_a_steeper_slope_that_friction_holds(tmp_path: Path) -> None:
    """Slope 14 degrees: friction holds the foot (tan 14 = 0.25 < 0.3), but
    the push would have to act h tan 14 (about 36 mm) downhill of the foot's
    middle, beyond even its half diagonal (28.3 mm: however the square foot is
    turned): the post falls over. E507 at the connection, how far beyond the
    edge (between h tan 14 - 28.3, across a corner, and h tan 14 - 20, across
    a side), falls_apart."""
    result = solve_text(tmp_path, POST_ON_RAMP.format(slope=14))
    assert result.status == "falls_apart"
    (topple,) = [d for d in result.diagnostics if d.code == "E507"]
    assert "`post` falls over on `ramp`" in topple.message
    assert "the floor slopes 14 degrees" in topple.message
    falls = result.solution.falls
    assert len(falls) == 1 and isinstance(falls[0], Topple)
    lever = post_height(result) * np.tan(np.radians(14))
    assert lever - 20.0 * np.sqrt(2.0) - 1.0 < falls[0].beyond_mm < lever - 20.0 + 1.0
