"""ElementKind / ElementSpec / Element: parsing, constructors, validation, serialisation."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core.elements import PALETTE, Element, ElementKind, ElementSpec, color_for
from code_as_monitor.core.errors import ElementError


def test_kind_parse_and_counts() -> None:
    assert ElementKind.parse(" Surface ") is ElementKind.SURFACE
    assert ElementKind.parse(ElementKind.LINE) is ElementKind.LINE
    assert (ElementKind.SURFACE.min_points, ElementKind.SURFACE.max_points) == (3, 4)
    with pytest.raises(ElementError, match=r"unknown element kind 'blob'.*point, line, surface"):
        ElementKind.parse("blob")


def test_spec_round_trip_and_validation() -> None:
    s = ElementSpec("pen axis", "pen", "body", "line")
    assert s.kind is ElementKind.LINE
    assert ElementSpec.from_dict(s.to_dict()) == s
    assert ElementSpec.from_dict({"name": "x", "obj": "cup"}).kind is ElementKind.POINT
    with pytest.raises(ElementError, match="'cone'"):
        ElementSpec("x", "cup", "", "cone")


def test_constructors_and_colours() -> None:
    p = Element.point(1, "tip", np.array([0.1, 0.2, 0.3]), ("robot", "tip"))
    assert p.points.shape == (1, 3) and p.color == color_for(1) == PALETTE[1]
    assert color_for(len(PALETTE) + 2) == PALETTE[2]
    L = Element.line(2, "pen", np.zeros(3), np.ones(3))
    assert L.kind is ElementKind.LINE and L.points.shape == (2, 3)
    S = Element.surface(3, "top", np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]), color=(1, 2, 3))
    assert S.color == (1, 2, 3)
    np.testing.assert_allclose(S.centroid(), [0.5, 0.5, 0.0])
    assert Element(0, "flat", "point", np.zeros(3)).points.shape == (1, 3)  # (3,) accepted for a point


def test_round_trip() -> None:
    S = Element.surface(3, "top", np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0.123456789]]), ("box", "top"))
    back = Element.from_dict(S.to_dict())
    assert (back.id, back.name, back.kind, back.owner, back.color) == (3, "top", S.kind, ("box", "top"), S.color)
    np.testing.assert_allclose(back.points, S.points, atol=1e-5)


@pytest.mark.parametrize(
    ("kind", "pts", "message"),
    [
        ("point", np.zeros((2, 3)), "needs 1-1 points, got 2"),
        ("line", np.zeros((1, 3)), "needs 2-2 points, got 1"),
        ("surface", np.zeros((5, 3)), "needs 3-4 points, got 5"),
        ("point", np.zeros((1, 2)), r"must be \(k, 3\)"),
        ("point", np.full((1, 3), np.nan), "NaN or inf"),
        ("line", np.zeros((2, 3)), "end points coincide"),
        ("surface", np.array([[0, 0, 0], [1, 1, 1], [2, 2, 2.0]]), "collinear"),
        ("ribbon", np.zeros((1, 3)), "unknown element kind 'ribbon'"),
    ],
)
def test_validation_names_the_problem(kind: str, pts: np.ndarray, message: str) -> None:
    with pytest.raises(ElementError, match=message):
        Element(0, "e", kind, pts)  # type: ignore[arg-type]


def test_clouds_and_support_are_optional_kept_and_counted_only() -> None:
    from code_as_monitor.core.elements import ElementSupport

    plain = Element.point(0, "p", [0.0, 0.0, 0.0])
    assert plain.cloud is None and plain.object_cloud is None and plain.support is None
    assert set(plain.to_dict()) == {"id", "name", "kind", "points", "owner", "color"}
    cloud = np.random.default_rng(0).normal(size=(50, 3))
    sup = ElementSupport(points=50, views=2, residual=0.0012, spread=0.02, extent=(0.04, 0.04, 0.03))
    e = Element.point(1, "block", [0.1, 0.0, 0.02], ("block", ""), cloud=cloud, object_cloud=cloud[:10], support=sup)
    d = e.to_dict()
    assert (d["cloud_points"], d["object_cloud_points"]) == (50, 10)
    assert "cloud" not in d and d["support"]["views"] == 2
    back = Element.from_dict(d)
    assert back.cloud is None and back.support == sup
    m = e.moved(np.array([[0.2, 0.0, 0.02]]))
    assert m.cloud is e.cloud and m.support is sup and m.points[0, 0] == 0.2
    assert "cloud" not in repr(e)  # the clouds are not printed
    assert sup.weak(min_points=60) and not sup.weak() and ElementSupport(5, 1, 0.0).weak()


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [("cloud", np.zeros((4, 2)), r"cloud must be \(M, 3\)"), ("object_cloud", np.full((2, 3), np.inf), "NaN or inf")],
)
def test_bad_clouds_are_named(field: str, value: np.ndarray, message: str) -> None:
    with pytest.raises(ElementError, match=message):
        Element.point(0, "p", [0.0, 0.0, 0.0], **{field: value})


def test_support_records_what_the_robot_hid_and_a_carry_over() -> None:
    from code_as_monitor.core.elements import ROBOT_HIDDEN_WEAK, ElementSupport

    hidden = ElementSupport(300, 2, 0.001, robot_hidden=ROBOT_HIDDEN_WEAK + 0.1, carried=True)
    assert hidden.weak() and not hidden.weak(max_robot_hidden=0.5)
    assert not ElementSupport(300, 2, 0.001, robot_hidden=ROBOT_HIDDEN_WEAK).weak()
    assert ElementSupport.from_dict(hidden.to_dict()) == ElementSupport(300, 2, 0.001, robot_hidden=0.4, carried=True)
    old = {k: v for k, v in hidden.to_dict().items() if k not in ("robot_hidden", "carried")}  # records before them
    assert ElementSupport.from_dict(old).robot_hidden == 0.0 and not ElementSupport.from_dict(old).carried
