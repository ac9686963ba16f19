"""Meshes built from primitives, and mass properties in grams."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fabhal.meshes import mass_properties, part_mesh, primitive_mesh
from fabhal.primitives import make_primitive
from tests.test_primitives import HERE, library, part


def test_hook_arc_mesh_is_closed_with_the_torus_section_volume() -> None:
    hook = make_primitive("h", "hook", {"arc_radius": 20, "arc_angle": 180, "thickness": 2}, {})
    mesh = primitive_mesh(hook)
    assert mesh.is_watertight
    exact = math.pi * 2**2 * 20 * math.pi  # wire area x centre-line length of a half circle
    # 1%: the 12-sided wire section keeps the circle's area; what is left is the arc's chords
    assert abs(mesh.volume - exact) / exact < 0.01
    # the arc runs from -z (theta 0) through -y: nothing lies above the centre's +y side
    assert mesh.bounds[1][1] <= 2.0 + 1e-9


def test_hemisphere_is_the_lower_half_ball() -> None:
    dome = primitive_mesh(make_primitive("d", "hemisphere", {"radius": 10}, {}))
    assert dome.is_watertight
    assert dome.bounds[1][2] <= 1e-9 and dome.bounds[0][2] < -9.5
    assert abs(dome.volume - 2 / 3 * math.pi * 1000) / (2 / 3 * math.pi * 1000) < 0.05


def test_mass_is_mesh_volume_times_density_in_grams() -> None:
    mass = mass_properties(part("DoubleHook"))
    # the reference's mesh volume, 1382.112 mm3, in steel of 7.85 g/cm3
    assert mass.mass_g == pytest.approx(1382.112 * 7.85 / 1000, rel=1e-6)
    assert mass.source == "mesh"
    np.testing.assert_allclose(mass.center_of_mass, (0, 0, 0), atol=1e-3)


def test_a_mass_line_wins_over_the_mesh() -> None:
    mug = mass_properties(part("Mug"))
    assert (mug.mass_g, mug.source) == (350.0, "mass line")
    assert mug.center_of_mass[2] > 20  # still the mesh's centroid: the mug body, not its handle


def test_a_part_without_a_mesh_is_drawn_from_its_primitives() -> None:
    extension = 30.0
    spec = library().instantiate("ParamTurnbuckle", {"extension": (extension, HERE)}, HERE)
    mesh = part_mesh(spec)
    half_length = 43.5 + extension / 2
    assert mesh.bounds[0][1] < -half_length + 1 and mesh.bounds[1][1] > half_length - 1
