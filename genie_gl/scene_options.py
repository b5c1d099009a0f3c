"""The typed options of the scene stage: a strategy's ``scene`` section (or ``build_scene``'s
``options=``), validated where it enters, when the strategy is loaded: an unknown key, a value
of the wrong kind or out of range is one line naming the key and what was expected.

At the bottom of the package (no imports of the stages) so that the strategy loader can check
the section it carries to the scene stage without importing that stage.
"""

from __future__ import annotations

from typing import Any, Optional, Union

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from .errors import ConfigError, did_you_mean


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, strict=False)


class Jitter(_Strict):
    position_m: float = Field(0.0, ge=0, le=100)
    yaw_rad: float = Field(0.0, ge=0, le=10)


class AssetFile(_Strict):
    path: str = Field(min_length=1)
    variant: Optional[str] = None
    units: Optional[Union[str, float]] = None
    up: Optional[str] = None


class SceneOptions(_Strict):
    """A strategy's ``scene`` section, typed (see :mod:`genie_gl.scene.build` for what each
    option does); every option has its default here, the builder reads the fields."""

    walls: bool = False
    wall_height_m: float = Field(5.0, gt=0, le=1000)
    columns: float = Field(0.0, ge=0, le=1e4)
    stack: bool = False
    stack_height_m: float = Field(1.6, gt=0, le=100)
    jitter: Optional[Jitter] = None
    dropout: float = Field(0.0, ge=0, le=1)
    color: bool = False
    clutter: float = Field(0.0, ge=0, le=1)
    assets: dict[str, list[Union[str, AssetFile]]] = {}

    @property
    def jitters(self) -> bool:
        """True when the section asks for jitter (a ``jitter`` with at least one value)."""
        return self.jitter is not None and bool(self.jitter.model_fields_set)

    def asset_entries(self) -> dict[str, list[dict[str, Any]]]:
        """The ``assets`` option as {class: [{"path", "variant", "units", "up"}, ...]}."""
        return {
            cls: [{"path": e} if isinstance(e, str) else e.model_dump() for e in entries]
            for cls, entries in self.assets.items()
        }


def scene_options(options: Any, where: str = "scene") -> SceneOptions:
    """``options`` (a strategy's ``scene`` section, a mapping) validated into
    :class:`SceneOptions`; None gives the defaults."""
    if options is None:
        return SceneOptions()
    if not isinstance(options, dict):
        raise ConfigError(f"{where}: expected an object of scene options, got {options!r:.60}")
    try:
        return SceneOptions(**options)
    except ValidationError as exc:
        e = exc.errors()[0]
        key = ".".join(str(p) for p in e["loc"])
        if e["type"] == "extra_forbidden":
            known = list(SceneOptions.model_fields)
            raise ConfigError(
                f"{where}.{key}: unknown scene option{did_you_mean(str(e['loc'][-1]), known)} "
                f"(known: {', '.join(known)})"
            ) from None
        raise ConfigError(f"{where}.{key}: {e['msg']} (got {e.get('input')!r:.60})") from None
