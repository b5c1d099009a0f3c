"""The planner's convexity test: trimesh's answer (closed, one body, locally convex) on shapes
that are and are not convex, computed once per mesh."""

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.scene import convexity


def shapes():
    s = trimesh.creation.icosphere(3)
    dented = s.vertices.copy()
    dented[0] *= 0.8
    return {
        "sphere": trimesh.creation.icosphere(4),
        "box": trimesh.creation.box((1, 2, 3)),
        "cylinder": trimesh.creation.cylinder(0.3, 2, sections=64),
        "cone": trimesh.creation.cone(1, 2),
        "capsule": trimesh.creation.capsule(1, 0.4),
        "torus": trimesh.creation.torus(1, 0.3),
        "annulus": trimesh.creation.annulus(0.5, 1, 1),
        "two boxes": trimesh.util.concatenate(
            [
                trimesh.creation.box((1, 1, 1)),
                trimesh.creation.box((1, 1, 1)).apply_translation([3, 0, 0]),
            ]
        ),
        "open sphere": trimesh.Trimesh(s.vertices, s.faces[:-5]),
        "dented sphere": trimesh.Trimesh(dented, s.faces),
    }


@pytest.mark.parametrize("name", list(shapes()))
def test_convexity_agrees_with_trimesh(name):
    m = shapes()[name]
    theirs = trimesh.Trimesh(m.vertices, m.faces, process=True)
    expected = bool(theirs.is_watertight and theirs.is_convex)
    assert convexity.convex_arrays(np.asarray(m.vertices), np.asarray(m.faces)) == expected
    assert expected == (name in {"sphere", "box", "cylinder", "cone", "capsule"})


def test_split_vertices_are_merged_and_a_flipped_face_is_not_convex():
    box = trimesh.creation.box((1, 1, 1))
    tri = np.asarray(box.vertices)[np.asarray(box.faces)].reshape(
        -1, 3
    )  # every face its own vertices
    faces = np.arange(len(tri)).reshape(-1, 3)
    assert convexity.convex_arrays(tri, faces)
    flipped = faces.copy()
    flipped[0] = flipped[0][::-1]
    assert not convexity.convex_arrays(tri, flipped)


def test_convexity_is_decided_once_per_geometry(monkeypatch):
    """Once per mesh object, and once per geometry: a new Mesh of the same vertices and faces
    (what a new scene of the same assets makes) finds the answer by its digest."""
    calls = []
    real = convexity.convex_arrays
    monkeypatch.setattr(convexity, "convex_arrays", lambda v, f: calls.append(1) or real(v, f))
    monkeypatch.setattr(convexity, "_BY_CONTENT", {})
    ball = trimesh.creation.icosphere(2)
    mesh = gg.Mesh(np.asarray(ball.vertices), np.asarray(ball.faces), closed=True)
    assert convexity.is_convex(mesh) and convexity.is_convex(mesh)
    assert len(calls) == 1
    other = gg.Mesh(mesh.vertices.copy(), mesh.faces.copy(), closed=True)
    assert convexity.is_convex(other) and len(calls) == 1
    dented = np.asarray(ball.vertices).copy()
    dented[0] *= 0.5
    assert (
        not convexity.is_convex(gg.Mesh(dented, np.asarray(ball.faces), closed=True))
        and len(calls) == 2
    )
