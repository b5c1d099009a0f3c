"""USD in and out: the only module that imports ``pxr``.

Written stages are Z up, metres; every distinct mesh is one prototype under the class prim
``/Prototypes`` and every instance an instanceable Xform referencing it (scenegraph
instancing), with a full-precision ``xformOp:transform``, its class labelled both through the
SemanticsAPI that Omniverse Replicator reads and the newer UsdSemantics labels, its instance
id as ``genie:instanceId`` and its colour as a constant ``primvars:displayColor``.

Every distinct material is a ``UsdShade.Material`` under ``/World/Looks`` whose surface is a
``UsdPreviewSurface`` shader (inputs ``diffuseColor``, ``metallic``, ``roughness``,
``opacity``, ``ior``), bound to its instances with ``MaterialBindingAPI``.

Reading accepts any stage: meshes with any face sizes (fan-triangulated), implicit gprims
(``Sphere``, ``Cube``, ``Cylinder``, ``Cone``, ``Capsule``: tessellated with ``segments``
per circle, an accuracy knob), xform stacks, references, payloads, variants, scenegraph
instancing and PointInstancers, Y-up and other units, labels in either API, and the bound
UsdPreviewSurface inputs of each prim (a prim without one gets no material, read by effects
as :data:`~genie_gl.scene.model.DEFAULT_MATERIAL`, UsdPreviewSurface's own defaults; how many
prims had none is ``scene.metadata["prims_without_material"]``).
"""

from __future__ import annotations

import errno
import logging
import os
import re
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdShade, Vt

from .. import __version__, labels
from ..validation.arguments import MAX_COORD_M, expect, expect_path, whole_number
from ..limits import MAX_INSTANCES, check_instances
from ..errors import ConfigError
from ..outputs import check_replaceable, written
from .gprims import tessellate
from .model import Material, Mesh, Scene

log = logging.getLogger(__name__)

CLASS_NAMES = labels.CLASSES  # the one label map (genie_gl/labels.py)


def _ident(name: str, fallback: str) -> str:
    s = re.sub(r"[^A-Za-z0-9_]", "_", name or fallback)
    return s if s and not s[0].isdigit() else f"_{s}"


def written_by_genie(path: str | os.PathLike) -> bool:
    """True when the USD file ``path`` was written by genie-gl (its layer's custom data)."""
    layer = Sdf.Layer.OpenAsAnonymous(str(path))
    return layer is not None and "genie_gl" in dict(layer.customLayerData)


def write_usd(scene: Scene, path: str | os.PathLike) -> Path:
    """Write ``scene`` to ``path`` (.usda text or .usd/.usdc binary), via a temporary file."""
    expect(scene, Scene, "write_usd: scene")
    path = expect_path(path, "write_usd: path")
    if path.suffix not in (".usda", ".usdc", ".usd"):
        raise ConfigError(f"{path}: USD files end in .usda, .usdc or .usd")
    check_replaceable(path, written_by_genie, what="USD scene")
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")
    with written(path, tmp):
        _write_stage(scene, tmp, path)
        tmp.replace(path)
    return path


def _write_stage(scene: Scene, tmp: Path, path: Path) -> None:
    try:
        stage = Usd.Stage.CreateNew(str(tmp))
        _fill_stage(scene, stage)
        ok = stage.GetRootLayer().Save()
    except (
        Tf.ErrorException
    ) as exc:  # USD reports a failed write (a full disk ...) as its own error
        why = re.search(r"Error occurred writing file: ([^'\n]*)", str(exc)) or re.search(
            r" : '([^\n]*)'", str(exc)
        )
        text = why.group(1) if why else "USD could not write the file"
        code = next(
            (
                e
                for e in (errno.ENOSPC, errno.EFBIG, errno.EDQUOT, errno.EROFS, errno.EACCES)
                if os.strerror(e) in text
            ),
            errno.EIO,
        )
        raise OSError(code, text, str(path)) from None
    if not ok:
        raise OSError(errno.EIO, "USD could not save the stage", str(path))


def _fill_stage(scene: Scene, stage: Usd.Stage) -> None:
    stage.GetRootLayer().customLayerData = {
        "genie_gl": __version__
    }  # how a later write knows it is ours
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    protos = stage.CreateClassPrim("/Prototypes")
    proto_path = {}
    for key in sorted(scene.meshes):
        m = scene.meshes[key]
        p = protos.GetPath().AppendChild(_ident(key, "mesh"))
        UsdGeom.Xform.Define(stage, p)
        mesh = UsdGeom.Mesh.Define(stage, p.AppendChild("Geom"))
        pts = Vt.Vec3fArray.FromNumpy(m.vertices)
        mesh.CreatePointsAttr(pts)
        mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(m.faces), 3, np.int32)))
        mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(m.faces.astype(np.int32).ravel()))
        mesh.CreateExtentAttr(UsdGeom.PointBased.ComputeExtent(pts))
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        mesh.CreateDoubleSidedAttr(not m.closed)
        mesh.GetPrim().CreateAttribute("genie:closed", Sdf.ValueTypeNames.Bool).Set(bool(m.closed))
        proto_path[key] = p
    looks = UsdGeom.Scope.Define(stage, world.GetPath().AppendChild("Looks"))
    materials: dict[Material, UsdShade.Material] = {}
    used: set[str] = set()
    for inst in scene.instances:
        name = _ident(inst.name, f"instance_{inst.instance}")
        if name in used:
            name = f"{name}_{inst.instance}"
        used.add(name)
        x = UsdGeom.Xform.Define(stage, world.GetPath().AppendChild(name))
        x.AddTransformOp().Set(Gf.Matrix4d(inst.world_from_model.T.tolist()))
        prim = x.GetPrim()
        prim.GetReferences().AddInternalReference(proto_path[inst.mesh])
        prim.SetInstanceable(True)
        label = labels.name(inst.semantic)
        prim.AddAppliedSchema("SemanticsAPI:Semantics")
        prim.CreateAttribute(
            "semantic:Semantics:params:semanticType", Sdf.ValueTypeNames.String
        ).Set("class")
        prim.CreateAttribute(
            "semantic:Semantics:params:semanticData", Sdf.ValueTypeNames.String
        ).Set(label)
        prim.AddAppliedSchema("SemanticsLabelsAPI:class")
        prim.CreateAttribute("semantics:labels:class", Sdf.ValueTypeNames.TokenArray).Set([label])
        prim.CreateAttribute("genie:semanticId", Sdf.ValueTypeNames.Int).Set(int(inst.semantic))
        prim.CreateAttribute("genie:instanceId", Sdf.ValueTypeNames.UInt).Set(int(inst.instance))
        pv = UsdGeom.PrimvarsAPI(prim).CreatePrimvar(
            "displayColor", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.constant
        )
        pv.Set([Gf.Vec3f(*(c / 255.0 for c in inst.color))])
        if inst.material is not None:
            mat = materials.get(inst.material)
            if mat is None:
                mat = materials[inst.material] = _define_material(
                    stage,
                    looks.GetPath().AppendChild(f"Material_{len(materials):04d}"),
                    inst.material,
                )
            UsdShade.MaterialBindingAPI.Apply(prim).Bind(mat)


GPRIMS = {
    "Sphere": UsdGeom.Sphere,
    "Cube": UsdGeom.Cube,
    "Cylinder": UsdGeom.Cylinder,
    "Cone": UsdGeom.Cone,
    "Capsule": UsdGeom.Capsule,
}


def _gprim(prim: Usd.Prim) -> tuple[str, dict]:
    """(kind, parameters) of an implicit gprim; attributes unauthored take USD's fallbacks."""
    for kind, schema in GPRIMS.items():
        if prim.IsA(schema):
            g = schema(prim)
            if kind == "Cube":
                return kind, {"size": float(g.GetSizeAttr().Get())}
            params = {"radius": float(g.GetRadiusAttr().Get())}
            if kind != "Sphere":
                params["height"] = float(g.GetHeightAttr().Get())
                params["axis"] = str(g.GetAxisAttr().Get())
            return kind, params
    raise ConfigError(f"{prim.GetPath()}: not an implicit gprim")


def _define_material(stage: Usd.Stage, path: Sdf.Path, m: Material) -> UsdShade.Material:
    mat = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, path.AppendChild("PreviewSurface"))
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*m.diffuse_color))
    for name in ("metallic", "roughness", "opacity", "ior"):
        shader.CreateInput(name, Sdf.ValueTypeNames.Float).Set(getattr(m, name))
    mat.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return mat


_INPUTS = {
    "diffuseColor": "diffuse_color",
    "metallic": "metallic",
    "roughness": "roughness",
    "opacity": "opacity",
    "ior": "ior",
}


def _material(prim: Usd.Prim) -> Material | None:
    """The UsdPreviewSurface inputs bound to ``prim`` (None when it has no such material).

    An input without an authored value, or connected to a texture, takes the
    UsdPreviewSurface default (:class:`Material`'s)."""
    mat, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
    if not mat:
        return None
    shader, _, _ = mat.ComputeSurfaceSource()
    if not shader or shader.GetIdAttr().Get() != "UsdPreviewSurface":
        return None
    values = {}
    for usd_name, field in _INPUTS.items():
        inp = shader.GetInput(usd_name)
        if not inp:
            continue
        attrs = inp.GetValueProducingAttributes()
        if not attrs or not UsdShade.Input.IsInput(attrs[0]):
            continue  # driven by a texture or another node's output
        value = attrs[0].Get()
        if value is None:
            continue
        values[field] = (
            tuple(float(c) for c in value) if usd_name == "diffuseColor" else float(value)
        )
    try:
        return Material(**values)
    except ConfigError as exc:
        raise ConfigError(f"material {mat.GetPath()}: {exc}") from None


def _label(prim: Usd.Prim) -> tuple[int | None, int | None]:
    """(semantic id, instance id) from the nearest labelled ancestor."""
    sem = inst = None
    p = prim
    while p and p.GetPath() != Sdf.Path.absoluteRootPath:
        if inst is None and p.HasAttribute("genie:instanceId"):
            inst = int(p.GetAttribute("genie:instanceId").Get())
        if sem is None:
            if p.HasAttribute("genie:semanticId"):
                sem = int(p.GetAttribute("genie:semanticId").Get())
            else:
                name = None
                a = p.GetAttribute("semantics:labels:class")
                if a and a.HasAuthoredValue() and len(a.Get() or []):
                    name = str(a.Get()[0])
                else:
                    b = p.GetAttribute("semantic:Semantics:params:semanticData")
                    if b and b.HasAuthoredValue():
                        name = str(b.Get())
                if name is not None:
                    sem = labels.class_id(name)
                    sem = 0 if sem is None else sem
        p = p.GetParent()
    return sem, inst


def _triangulate(counts: np.ndarray, indices: np.ndarray) -> np.ndarray:
    faces, start = [], 0
    for c in counts:
        if c >= 3:
            idx = indices[start : start + c]
            faces.extend([idx[0], idx[k], idx[k + 1]] for k in range(1, c - 1))
        start += c
    return np.array(faces, dtype=np.int64).reshape(-1, 3)


def read_usd(
    path: str | os.PathLike,
    *,
    meters_per_unit: float | None = None,
    up_axis: str | None = None,
    segments: int = 32,
    max_instances: int = MAX_INSTANCES,
) -> Scene:
    """Read any USD stage into a Scene (world Z up, metres).

    ``meters_per_unit`` and ``up_axis`` ("y" or "z") override the stage's ``metersPerUnit``
    and ``upAxis`` (whose fallbacks, when unauthored, are USD's: centimetres and Y up).
    ``segments`` (>= 3): segments per circle of tessellated implicit gprims (a sphere of
    radius r deviates from its facets by at most r·(1 − cos(π/segments))). A stage of more
    than ``max_instances`` instances (a point instancer's are counted before any is read) is
    refused (:class:`~genie_gl.errors.LimitError`).
    """
    path = expect_path(path, "read_usd: path")
    if isinstance(segments, bool) or not isinstance(segments, (int, np.integer)) or segments < 3:
        raise ConfigError(
            f"read_usd: segments must be an integer >= 3 (segments per circle), got {segments!r}"
        )
    max_instances = whole_number(max_instances, "read_usd: max_instances", 1)
    if not path.is_file():
        raise ConfigError(f"{path}: no such USD file")
    try:
        stage = Usd.Stage.Open(str(path), Usd.Stage.LoadAll)
    except Tf.ErrorException as exc:
        m = re.search(r" : '([^\n]*)", str(exc))  # the first of USD's "Error in ... : 'why'"
        why = m.group(1).rstrip("'") if m else str(exc).strip()
        raise ConfigError(
            f"{path}: USD could not open the stage ({why}); expected a USD layer"
        ) from None
    if stage is None:
        raise ConfigError(f"{path}: USD could not open the stage")
    mpu = (
        UsdGeom.GetStageMetersPerUnit(stage) if meters_per_unit is None else float(meters_per_unit)
    )
    if not (np.isfinite(mpu) and 0 < mpu <= 1e6):
        raise ConfigError(
            f"{path}: metersPerUnit {mpu}: expected a number > 0 (1 = metres, 0.01 = centimetres)"
        )
    up = UsdGeom.GetStageUpAxis(stage) if up_axis is None else str(up_axis).upper()
    if up not in (
        UsdGeom.Tokens.y,
        UsdGeom.Tokens.z,
    ):  # USD knows these two; another is not read as Z
        raise ConfigError(
            f"{path}: upAxis {up!r}: a USD stage is Y or Z up; fix the stage's upAxis (or read it "
            "with "
            "up_axis='y' or 'z')"
        )
    fix = np.eye(4) * mpu
    fix[3, 3] = 1.0
    if up == UsdGeom.Tokens.y:  # Y up -> Z up: +90 deg about x
        fix = fix @ np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1.0]])
    scene = Scene()
    cache = UsdGeom.XformCache()
    keys: dict[str, str] = {}
    next_id = [1]
    taken: set[int] = set()

    def mesh_key(mesh_prim: Usd.Prim) -> str | None:
        src = mesh_prim.GetPrimInPrototype() if mesh_prim.IsInstanceProxy() else mesh_prim
        k = str(src.GetPath())
        if k not in keys and not mesh_prim.IsA(UsdGeom.Mesh):
            kind, params = _gprim(mesh_prim)
            keys[k] = scene.add_mesh(
                tessellate(kind, int(segments), **params), name=_ident(src.GetName(), "mesh")
            )
        if k not in keys:
            m = UsdGeom.Mesh(mesh_prim)
            pts = m.GetPointsAttr().Get()
            counts, idx = m.GetFaceVertexCountsAttr().Get(), m.GetFaceVertexIndicesAttr().Get()
            if pts is None or counts is None or idx is None or len(pts) == 0:
                return None
            v = np.asarray(pts, dtype=np.float64)
            if not np.all(np.isfinite(v)):
                raise ConfigError(f"{path}: mesh {mesh_prim.GetPath()} has NaN or Inf points")
            if np.abs(v).max(initial=0.0) * mpu > MAX_COORD_M:
                raise ConfigError(
                    f"{path}: mesh {mesh_prim.GetPath()}: a point {np.abs(v).max():.3g} units from "
                    "its "
                    f"origin, beyond {MAX_COORD_M:g} m (absurd coordinates; check the stage's "
                    "units)"
                )
            counts, idx = np.asarray(counts, np.int64), np.asarray(idx, np.int64)
            if (
                (counts < 0).any()
                or counts.sum() != len(idx)
                or (len(idx) and (idx.min() < 0 or idx.max() >= len(v)))
            ):
                raise ConfigError(
                    f"{path}: mesh {mesh_prim.GetPath()}: faceVertexCounts (sum {int(counts.sum())}"
                    ") and "
                    f"faceVertexIndices ({len(idx)} indices into {len(v)} points) do not agree"
                )
            faces = _triangulate(counts, idx)
            keys[k] = scene.add_mesh(Mesh(v, faces), name=_ident(src.GetName(), "mesh"))
        return keys[k]

    authored: dict[int, str] = {}  # genie:instanceId -> the prim that authored it
    missing = [0]

    looks: dict[
        str, tuple
    ] = {}  # a point instancer's prototype prim -> (labels, material), read once

    def place(key: str, world: np.ndarray, prim: Usd.Prim, name: str, shared: bool = False) -> None:
        if shared:
            if str(prim.GetPath()) not in looks:
                looks[str(prim.GetPath())] = (_label(prim), _material(prim))
            (sem, inst), material = looks[str(prim.GetPath())]
        else:
            (sem, inst), material = _label(prim), None
        if inst is not None:
            owner = prim
            while owner and not owner.HasAttribute("genie:instanceId"):
                owner = owner.GetParent()
            where = str(owner.GetPath()) if owner else str(prim.GetPath())
            if prim.IsInstanceProxy():
                where = str(owner.GetPrimInPrototype().GetPath()) if owner else where
            if authored.setdefault(inst, where) != where and not prim.IsInstanceProxy():
                raise ConfigError(
                    f"{path}: genie:instanceId {inst} is authored on both {authored[inst]} and "
                    f"{where}; "
                    "expected one id per object"
                )
        if inst is None or inst in taken:
            while next_id[0] in taken:
                next_id[0] += 1
            inst = next_id[0]
        if not shared:
            material = _material(prim)
        # a prim with a zero or singular scale (a common way to hide one) is dropped and
        # counted in Scene.report(), named by its path
        if scene.add(
            key,
            fix @ world,
            semantic=sem or 0,
            instance=inst,
            name=name,
            degenerate="drop",
            where=str(prim.GetPath()),
            material=material,
        ):
            taken.add(inst)
            missing[0] += material is None

    def is_geometry(p: Usd.Prim) -> bool:
        return p.IsA(UsdGeom.Mesh) or any(p.IsA(t) for t in GPRIMS.values())

    for prim in stage.Traverse(Usd.TraverseInstanceProxies(Usd.PrimAllPrimsPredicate)):
        if not prim.IsActive() or prim.IsAbstract() or _in_instancer(prim):
            continue
        if is_geometry(prim):
            if len(scene.instances) >= max_instances:
                check_instances(len(scene.instances) + 1, max_instances, str(path))
            key = mesh_key(prim)
            if key is not None:
                world = np.array(cache.GetLocalToWorldTransform(prim)).T
                place(
                    key,
                    world,
                    prim,
                    prim.GetParent().GetName() if prim.IsInstanceProxy() else prim.GetName(),
                )
        elif prim.IsA(UsdGeom.PointInstancer):
            pi = UsdGeom.PointInstancer(prim)
            ids = np.asarray(pi.GetProtoIndicesAttr().Get() or [], np.int64)
            targets = pi.GetPrototypesRel().GetTargets()
            if len(ids) and (ids.min() < 0 or ids.max() >= len(targets)):
                raise ConfigError(
                    f"{path}: point instancer {prim.GetPath()}: protoIndices up to {int(ids.max())}"
                    " for "
                    f"{len(targets)} prototypes"
                )
            # every prototype's meshes relative to its root, once (not once per instance)
            parts = []
            for t in targets:
                proto = stage.GetPrimAtPath(t)
                inv = np.linalg.inv(np.array(cache.GetLocalToWorldTransform(proto)).T)
                parts.append(
                    [
                        (sub, inv @ np.array(cache.GetLocalToWorldTransform(sub)).T)
                        for sub in Usd.PrimRange(proto)
                        if is_geometry(sub)
                    ]
                )
            count = int(sum(len(parts[k]) for k in ids)) if len(ids) else 0
            check_instances(
                len(scene.instances) + count,
                max_instances,
                f"{path}: point instancer {prim.GetPath()}",
            )
            xf = pi.ComputeInstanceTransformsAtTime(Usd.TimeCode.Default(), Usd.TimeCode.Default())
            base = np.array(cache.GetLocalToWorldTransform(prim)).T
            for j, (pidx, m) in enumerate(zip(ids.tolist(), xf)):
                world = base @ np.array(m).T
                for sub, rel in parts[pidx]:
                    key = mesh_key(sub)
                    if (
                        key is not None
                    ):  # mesh relative to its prototype root, then the instance, then the instancer
                        place(key, world @ rel, sub, f"{prim.GetName()}_{j}", shared=True)
    if not scene.instances:
        raise ConfigError(f"{path}: the stage holds no mesh")
    scene.metadata["prims_without_material"] = missing[0]
    if missing[0]:
        log.info(
            "%s: %d of %d prims have no UsdPreviewSurface material (read as the default)",
            path,
            missing[0],
            len(scene.instances),
        )
    return scene


def _in_instancer(prim: Usd.Prim) -> bool:
    p = prim.GetParent()
    while p and p.GetPath() != Sdf.Path.absoluteRootPath:
        if p.IsA(UsdGeom.PointInstancer):
            return True
        p = p.GetParent()
    return False
