"""The reference tables of every scene key (docs/simulate.md is generated from them)."""

from __future__ import annotations

import dataclasses

from xlotkit.sim.scene.keys import SCENE_KEYS, _spec
from xlotkit.sim.scene.sections import _SECTION_TYPES

__all__ = ["scene_reference_markdown"]


def _default_text(section: str, key: str) -> str:
    if section == "":
        return {"title": '""', "model": '"auto"', "coupling": '"monolithic"',
                "seed": "0"}[key]
    if section == "effects" and key == "interface":
        return "none"
    cls = _SECTION_TYPES[section]
    f = {x.name: x for x in dataclasses.fields(cls)}[key]
    v = f.default
    if v is None:
        return "derived" if _spec(section, key).optional else "none"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return f"{v:.6g}"
    return f'"{v}"' if isinstance(v, str) else str(v)


def scene_reference_markdown() -> str:
    """Markdown tables of every scene key: unit, default, allowed values, meaning."""
    out = []
    for sec, keys in SCENE_KEYS.items():
        out.append(f"### {'top level' if not sec else '[' + sec + ']'}\n")
        out.append("| key | unit | default | allowed | meaning |")
        out.append("|---|---|---|---|---|")
        for k, sp in keys.items():
            allowed = "" if sp.kind in ("str", "interfaces") else sp.range_text()
            if sp.optional:
                allowed += " (or absent)"
            out.append(f"| `{k}` | {sp.unit or '-'} | {_default_text(sec, k)} | {allowed} | "
                       f"{sp.doc} |")
        out.append("")
    return "\n".join(out)
