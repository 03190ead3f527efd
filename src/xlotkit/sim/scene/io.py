"""Reading scenes: a TOML file or a mapping into a validated :class:`Scene`."""

from __future__ import annotations

import dataclasses
import re
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from xlotkit.errors import InputError
from xlotkit.sim.scene.keys import _SECTIONS, SCENE_KEYS, _LUMPED_FORMAT, _to_si
from xlotkit.sim.scene.lumped import lumped_scene_from_dict
from xlotkit.sim.scene.model import Scene
from xlotkit.sim.scene.quantities import angle as _angle
from xlotkit.sim.scene.quantities import quantity as _quantity
from xlotkit.sim.scene.sections import _SECTION_TYPES, Interface
from xlotkit.sim.schedule import Schedule

__all__ = ["load_scene", "scene_from_dict", "standard_2d_scene"]


def scene_from_dict(data: Mapping[str, Any], *, file: str | None = None,
                    text: str | None = None) -> Scene:
    """Build a :class:`Scene` from a mapping laid out like a scene file.

    Parameters
    ----------
    data : mapping
        The parsed TOML.
    file : str, optional
        Named in errors; relative ``mesh.file`` paths are taken from its folder.
    text : str, optional
        The file's text, kept in :attr:`Scene.source_text`.

    Raises
    ------
    InputError
        One error naming the file, the dotted key (``rock.permeability``), the value given
        and the allowed range; an unknown section or key lists the allowed ones.
    """
    try:
        return _build(data, file=file, text=text)
    except InputError as exc:
        if exc.file is None and file is not None:
            raise InputError(exc.message, file=file, line=exc.line, key=exc.key,
                             expected=exc.expected) from None
        raise


def _build(data: Mapping[str, Any], *, file: str | None, text: str | None) -> Scene:
    if not isinstance(data, Mapping):
        raise InputError("a scene must be a table", key="scene",
                         expected="a mapping of sections")
    if _LUMPED_FORMAT & set(data) and not (set(data) - {"title", "rock", "fluid", "output",
                                                        "schedule"} - _LUMPED_FORMAT):
        ls = lumped_scene_from_dict(data, file=file)
        sc = Scene.from_lumped(ls, source_text=text, source_file=file)
        title = data.get("title")
        return dataclasses.replace(sc, title=str(title)) if isinstance(title, str) else sc
    top = SCENE_KEYS[""]
    kw: dict[str, Any] = {}
    given: set[str] = set()
    for name, body in data.items():
        if name in top:
            kw[name] = _to_si("", name, body)
            given.add(name)
            continue
        if name not in _SECTIONS:
            raise InputError(f"unknown section or key {name!r}", key=name,
                             expected="one of " + ", ".join([*top, *_SECTIONS]))
        given.add(name)
        if name == "schedule":
            kw["schedule"] = Schedule.from_dict(body, key="schedule")
            continue
        if not isinstance(body, Mapping):
            raise InputError("must be a table", key=name, expected=f"a [{name}] table")
        allowed = SCENE_KEYS[name]
        skw: dict[str, Any] = {}
        for k, v in body.items():
            if k not in allowed:
                raise InputError(f"unknown key {k!r}", key=f"{name}.{k}",
                                 expected="one of " + ", ".join(allowed))
            if name == "effects" and k == "interface":
                skw[k] = _interfaces(v)
            else:
                skw[k] = _to_si(name, k, v)
            given.add(f"{name}.{k}")
        if name == "mesh" and skw.get("file"):
            mf = Path(skw["file"])
            if file is not None and not mf.is_absolute():
                mf = Path(file).parent / mf
            if not mf.is_file():
                raise InputError(f"no such mesh file {skw['file']!r}", key="mesh.file",
                                 expected="a triangle mesh readable by meshio (relative "
                                          "to the scene file)")
            skw["file"] = str(mf)
        try:
            kw[name] = _SECTION_TYPES[name](**skw)
        except InputError as exc:
            # a cross-check (sigma_H >= sigma_h, ...) reports SI values: add what was given
            k = (exc.key or "").removeprefix(name + ".")
            msg = exc.message
            if k in body and isinstance(body[k], str):
                msg += f" (given {body[k]!r})"
            raise InputError(msg, key=exc.key, expected=exc.expected) from None
    if "schedule" not in kw:
        raise InputError("missing [schedule]", key="schedule",
                         expected="a [schedule] table with [[schedule.phase]] entries")
    return Scene(**kw, given=frozenset(given), source_text=text, source_file=file)


def _interfaces(v: Any) -> tuple[Interface, ...]:
    if not isinstance(v, list):
        raise InputError("must be a list of tables", key="effects.interface",
                         expected="[[effects.interface]] tables with start, end")
    out = []
    for i, d in enumerate(v):
        key = f"effects.interface[{i}]"
        if not isinstance(d, Mapping):
            raise InputError("must be a table", key=key, expected="start, end, friction_angle")
        extra = set(d) - {"start", "end", "friction_angle"}
        if extra:
            raise InputError(f"unknown key {sorted(extra)[0]!r}", key=f"{key}.{sorted(extra)[0]}",
                             expected="one of start, end, friction_angle")
        try:
            pts = {n: [_quantity(x, "length", f"{key}.{n}") for x in d.get(n, ())]
                   for n in ("start", "end")}
            fa = _angle(d.get("friction_angle", 30.0), f"{key}.friction_angle")
            out.append(Interface(start=tuple(pts["start"]), end=tuple(pts["end"]),
                                 friction_angle=fa))
        except InputError as exc:
            k = (exc.key or "").replace("interface.", f"{key}.", 1)
            raise InputError(exc.message, key=k, expected=exc.expected) from None
        except TypeError:
            raise InputError("start and end must be [x, y] lists", key=key,
                             expected="[x, y] in m") from None
    return tuple(out)


def load_scene(path: str | Path) -> Scene:
    """Read a scene file (the layout above, or the lumped layout of
    :func:`xlotkit.sim.lumped.load_lumped_scene`).

    Raises
    ------
    InputError
        If the file cannot be read, is not valid TOML (with the line), or a key is unknown,
        of the wrong unit or out of range.
    """
    p = Path(path)
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read scene file: {exc.strerror}", file=str(p)) from None
    try:
        text = raw.decode("utf-8")
        data = tomllib.loads(text)
    except UnicodeDecodeError:
        raise InputError("not a UTF-8 text file", file=str(p)) from None
    except tomllib.TOMLDecodeError as exc:
        m = re.search(r"line (\d+)", str(exc))
        raise InputError(f"not valid TOML: {exc}", file=str(p),
                         line=int(m.group(1)) if m else None) from None
    return scene_from_dict(data, file=str(p), text=text)


def standard_2d_scene() -> Scene:
    """The standard two-cycle XLOT on the 2D model (what ``xlotkit demo`` simulates).

    Shipped with the package (``xlotkit/sim/scenes/standard_2d.toml``; the same file as
    ``examples/scene_2d_standard.toml``): the thesis's 2000 m well (~67 l/MPa), sigma_H
    40 / sigma_h 30 MPa, p0 20 MPa, T0 3 MPa with K_IC 1 MPa m^0.5 at crack tips, a 50 m
    section with a crack strip along sigma_H whose failed clusters close as a smooth joint;
    500 l/min pump-ins of 1.1 and 0.6 m^3, shut-ins and choke flowbacks (300 l/min at
    opening) to 27 MPa and to 2 MPa at surface.
    """
    from importlib.resources import as_file, files

    with as_file(files("xlotkit.sim") / "scenes" / "standard_2d.toml") as path:
        return load_scene(path)


