"""The automatic sphere model of the bundled robots sticks out of the links by at most 1 cm and
covers them (issue 17), checked against an independent computation (tests/sphere_truth.py: exact
distance functions of the URDF's boxes, cylinders, capsules and spheres, evaluated with numpy)."""

from __future__ import annotations

import numpy as np
import pytest
import sphere_truth

import ferrobot

MAX_PROTRUSION = 0.01  # m, the automatic model's bound
TOLERANCE = 1e-3  # m, SphereModel.automatic's default coverage tolerance


@pytest.fixture(scope="module", params=["panda", "ur5e"])
def robot(request):
    model = ferrobot.robots.bundled(request.param)
    return request.param, model, ferrobot.SphereModel.automatic(model)


def test_every_sphere_is_within_the_bound_of_its_centre_depth(robot):
    """A sphere of radius r centred at depth d inside the link (the link holds the ball of
    radius d there) sticks out by at most r - d: a certificate for the whole sphere, not only
    sampled points."""
    name, model, spheres = robot
    for link in model.link_names:
        geoms = model.collision_geometry(link)
        s = np.asarray(spheres.spheres(link)).reshape(-1, 4)
        if not geoms:
            assert len(s) == 0
            continue
        elements = [sphere_truth._Element(g, 0.0015) for g in geoms]
        depth = -np.min([e.sd(s[:, :3]) for e in elements], axis=0)
        excess = s[:, 3] - depth
        assert excess.max() <= MAX_PROTRUSION + 1e-6, f"{name}: {link}: {excess.max() * 1e3:.2f} mm"


def test_protrusion_and_coverage_measured_on_the_surfaces(robot):
    name, model, spheres = robot
    fits = sphere_truth.measure_model(model, spheres, spacing=0.004, samples=5000, tol=TOLERANCE)
    assert fits, name
    for f in fits:
        assert f.spheres > 0, f"{name}: {f.link} has no sphere"
        assert f.max_protrusion <= MAX_PROTRUSION + 1e-6, f"{name}: {f.link}: {f.max_protrusion * 1e3:.2f} mm"
        # Every sampled surface point within the tolerance of a sphere.
        assert f.coverage == 1.0, f"{name}: {f.link}: coverage {f.coverage}, gap {f.worst_gap * 1e3:.2f} mm"
    # The model is not trivially small: something sticks out (a sphere cannot fit a box's
    # edges exactly), and the report agrees with the independent measurement within the sampling.
    worst = max(f.max_protrusion for f in fits)
    own = max(r.max_protrusion for r in spheres.report)
    assert 0.0 < worst and abs(worst - own) < 1.5e-3, (worst, own)
