"""read_usd on composed foreign stages: payloads to other files and variant selections."""

import numpy as np

import genie_gl as gg

EXACT = 1e-9

# a part in its own file: its default prim carries a translation and a variant set of two shapes
PART = """#usda 1.0
(
    defaultPrim = "Part"
    upAxis = "Z"
    metersPerUnit = 1
)
def Xform "Part" (
    variants = {
        string shape = "box"
    }
    prepend variantSets = "shape"
)
{
    double3 xformOp:translate = (0, 0, 1)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    variantSet "shape" = {
        "box" {
            def Mesh "BoxGeom"
            {
                point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
                int[] faceVertexCounts = [4]
                int[] faceVertexIndices = [0, 1, 2, 3]
            }
        }
        "wedge" {
            def Mesh "WedgeGeom"
            {
                point3f[] points = [(0, 0, 0), (2, 0, 0), (0, 0, 3)]
                int[] faceVertexCounts = [3]
                int[] faceVertexIndices = [0, 1, 2]
            }
        }
    }
}
"""

# the stage: the part as a payload under a moved Xform, its variant chosen here (the stronger
# layer); two instanceable payloads of it, one moved; and a prim of its own whose selected
# variant carries a mesh with its own transform
MAIN = """#usda 1.0
(
    defaultPrim = "World"
    upAxis = "Z"
    metersPerUnit = 1
)
def Xform "World"
{
    def Xform "Site"
    {
        double3 xformOp:translate = (5, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
        def Xform "Loaded" (
            prepend payload = @./part.usda@
            variants = {
                string shape = "wedge"
            }
        )
        {
        }
    }
    def Xform "CopyA" (
        instanceable = true
        prepend payload = @./part.usda@
    )
    {
    }
    def Xform "CopyB" (
        instanceable = true
        prepend payload = @./part.usda@
    )
    {
        double3 xformOp:translate = (0, -4, 0)
    }
    def Xform "Crate" (
        variants = {
            string size = "large"
        }
        prepend variantSets = "size"
    )
    {
        double3 xformOp:translate = (0, 3, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
        variantSet "size" = {
            "small" {
                def Mesh "SmallGeom"
                {
                    point3f[] points = [(0, 0, 0), (0.5, 0, 0), (0.5, 0.5, 0.5)]
                    int[] faceVertexCounts = [3]
                    int[] faceVertexIndices = [0, 1, 2]
                }
            }
            "large" {
                def Mesh "LargeGeom"
                {
                    double3 xformOp:scale = (2, 2, 2)
                    uniform token[] xformOpOrder = ["xformOp:scale"]
                    point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 1), (0, 1, 1)]
                    int[] faceVertexCounts = [4]
                    int[] faceVertexIndices = [0, 1, 2, 3]
                }
            }
        }
    }
}
"""


def _world_bounds(scene: gg.Scene) -> dict[str, np.ndarray]:
    out = {}
    for inst in scene.instances:
        m = scene.meshes[inst.mesh]
        w = np.c_[m.vertices.astype(np.float64), np.ones(len(m.vertices))] @ inst.world_from_model.T
        out[inst.name] = np.stack([w[:, :3].min(0), w[:, :3].max(0)])
    return out


def test_payload_to_another_file_with_a_variant_chosen_by_the_stage(tmp_path):
    (tmp_path / "part.usda").write_text(PART)
    (tmp_path / "main.usda").write_text(MAIN)
    scene = gg.read_usd(tmp_path / "main.usda")
    b = _world_bounds(scene)
    assert sorted(b) == ["CopyA", "CopyB", "LargeGeom", "WedgeGeom"]  # only the selected variants
    # wedge (0..2, 0, 0..3) + the part's own (0, 0, 1) + the site's (5, 0, 0)
    np.testing.assert_allclose(b["WedgeGeom"], [[5, 0, 1], [7, 0, 4]], atol=EXACT)
    # the large crate: its mesh scaled by 2 in the variant, then moved by (0, 3, 0)
    np.testing.assert_allclose(b["LargeGeom"], [[0, 3, 0], [2, 5, 2]], atol=EXACT)
    # instanceable payloads: one prototype mesh (the part's default "box"), two placements
    np.testing.assert_allclose(b["CopyA"], [[0, 0, 1], [1, 1, 1]], atol=EXACT)
    np.testing.assert_allclose(b["CopyB"], [[0, -4, 0], [1, -3, 0]], atol=EXACT)
    assert len({i.mesh for i in scene.instances if i.name.startswith("Copy")}) == 1


def test_payload_default_variant_and_a_usdc_payload(tmp_path):
    # without the stage's selection the part's own default variant ("box") is composed, and a
    # payload to a binary layer composes the same way
    from pxr import Sdf

    Sdf.Layer.FindOrOpen(str(_write(tmp_path / "part.usda", PART))).Export(
        str(tmp_path / "part.usdc")
    )
    main = MAIN.replace("@./part.usda@", "@./part.usdc@").replace('string shape = "wedge"', "")
    b = _world_bounds(gg.read_usd(_write(tmp_path / "main.usda", main)))
    assert sorted(b) == ["BoxGeom", "CopyA", "CopyB", "LargeGeom"]
    np.testing.assert_allclose(b["BoxGeom"], [[5, 0, 1], [6, 1, 1]], atol=EXACT)


def _write(path, text):
    path.write_text(text)
    return path
