#!/usr/bin/env python3
"""Writes a variant of a scene file with some keys changed, for the measurements in assets/report/.

    python3 assets/report/scene_variant.py IN.json OUT.json KEY=VALUE [KEY=VALUE ...]

KEY is a dotted path into the scene (list elements by index, e.g. bodies.0.horizon); VALUE is
parsed as JSON when it can be (1.45, "x", [1,2], {"a": 1}) and taken as a string otherwise; the
value `__delete__` removes the key. `bodies.*.KEY` sets KEY in every body. Relative mesh paths
(geometry.path) are made absolute, so OUT.json may live anywhere.

    python3 assets/report/scene_variant.py assets/scenes/paper/fig09_beam_stretch.preview.json \\
        out/nu/discrete.json model.normalization=discrete 'bodies.*.horizon=1.45'
"""
import json
import os
import sys


def parse(value):
    try:
        return json.loads(value)
    except ValueError:
        return value


def assign(node, keys, value):
    key = keys[0]
    if key == "*":
        for child in node:
            assign(child, keys[1:], value)
        return
    if isinstance(node, list):
        key = int(key)
    if len(keys) == 1:
        if value == "__delete__":
            node.pop(key, None) if isinstance(node, dict) else node.pop(key)
        else:
            node[key] = value
        return
    if isinstance(node, dict) and key not in node:
        node[key] = {}
    assign(node[key], keys[1:], value)


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    src, dst = sys.argv[1], sys.argv[2]
    scene = json.load(open(src))
    base = os.path.dirname(os.path.abspath(src))
    for body in scene.get("bodies", []):
        g = body.get("geometry", {})
        if "path" in g and not os.path.isabs(g["path"]):
            g["path"] = os.path.normpath(os.path.join(base, g["path"]))
    for item in sys.argv[3:]:
        key, _, value = item.partition("=")
        assign(scene, key.split("."), parse(value))
    os.makedirs(os.path.dirname(os.path.abspath(dst)), exist_ok=True)
    with open(dst, "w") as f:
        json.dump(scene, f, indent=1)


if __name__ == "__main__":
    main()
