"""Write a scene dict as a Mitsuba XML file that :func:`nlos_rs.load_file` (and Mitsuba, for the
plugins both read) loads back to the same scene."""

from __future__ import annotations

import os
from typing import Any, Mapping, Union
from xml.sax.saxutils import quoteattr

from .values import normalize

#: The XML tag of each plugin nlos_rs reads (or names in an error), by category.
_TAGS = {
    "shape": ("obj", "ply", "rectangle", "disk", "cube", "sphere", "serialized"),
    "emitter": ("projector", "area", "point", "angulararea", "spot", "constant", "envmap", "directional"),
    "sensor": ("nlos_capture_meter", "perspective", "thinlens", "orthographic"),
    "sampler": ("independent", "stratified", "multijitter", "orthogonal", "ldsampler"),
    "rfilter": ("box", "gaussian", "tent", "lanczos", "mitchell", "catmullrom"),
    "integrator": ("transient_nlos_path", "transient_nlos_path_rs", "transient_path", "path"),
}


def _tag(plugin: str) -> str:
    if plugin.endswith("film"):
        return "film"
    for tag, plugins in _TAGS.items():
        if plugin in plugins:
            return tag
    return "bsdf"


def _number(x: float) -> str:
    return repr(float(x))


def _element(name: str, v: Any, indent: str, top: bool) -> str:
    attr = f"id={quoteattr(name)}" if top else f"name={quoteattr(name)}"
    if isinstance(v, Mapping):
        kind = v.get("type")
        if kind == "ref":
            return f"{indent}<ref {'' if top else attr + ' '}id={quoteattr(str(v['id']))}/>\n"
        if kind in ("rgb", "spectrum"):
            val = v["value"]
            text = ", ".join(_number(x) for x in val) if isinstance(val, list) else str(val)
            return f"{indent}<{kind} {attr} value={quoteattr(text)}/>\n"
        if not isinstance(kind, str):
            raise ValueError(f"{name!r}: a nested dict needs a 'type'")
        body = "".join(_element(k, x, indent + "    ", False) for k, x in v.items() if k not in ("type", "id"))
        ident = v.get("id", name if top else None)
        head = f"{indent}<{_tag(kind)} type={quoteattr(kind)}"
        head += f" id={quoteattr(str(ident))}" if ident is not None else ""
        head += "" if top else f" {attr}"
        return f"{head}>\n{body}{indent}</{_tag(kind)}>\n"
    if isinstance(v, bool):
        return f"{indent}<boolean {attr} value=\"{'true' if v else 'false'}\"/>\n"
    if isinstance(v, int):
        return f"{indent}<integer {attr} value=\"{v}\"/>\n"
    if isinstance(v, float):
        return f"{indent}<float {attr} value=\"{_number(v)}\"/>\n"
    if isinstance(v, str):
        return f"{indent}<string {attr} value={quoteattr(v)}/>\n"
    if isinstance(v, list) and len(v) == 3 and all(isinstance(x, (int, float)) for x in v):
        return f"{indent}<point {attr} x=\"{_number(v[0])}\" y=\"{_number(v[1])}\" z=\"{_number(v[2])}\"/>\n"
    if isinstance(v, list) and len(v) == 4 and all(isinstance(r, list) and len(r) == 4 for r in v):
        values = " ".join(_number(x) for row in v for x in row)
        return f"{indent}<transform {attr}>\n{indent}    <matrix value=\"{values}\"/>\n{indent}</transform>\n"
    raise ValueError(f"{name!r}: cannot write {v!r} as XML")


def save_xml(scene: Mapping[str, Any], path: Union[str, os.PathLike]) -> None:
    """Write a scene dict (``{'type': 'scene', ...}``) as Mitsuba XML. Top-level objects get their
    dict key as ``id``; mesh ``filename``\\ s are written as given (relative paths resolve against
    the XML file's folder when it is loaded)."""
    d = normalize(scene)
    if not isinstance(d, Mapping) or d.get("type") != "scene":
        raise ValueError("save_xml expects a scene dict with 'type': 'scene'")
    body = "".join(_element(k, v, "    ", True) for k, v in d.items() if k != "type")
    with open(path, "w", encoding="utf-8") as f:
        f.write(f'<scene version="3.0.0">\n{body}</scene>\n')
