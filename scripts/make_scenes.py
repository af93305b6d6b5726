#!/usr/bin/env python3
"""Writes ProbeStudio's bundled default scenes (glTF 2.0, embedded data-URI buffers).

Usage: scripts/make_scenes.py [--unit-copies] [OUTPUT_DIR]
       (default OUTPUT_DIR: resources/scenes/ next to this script)

--unit-copies also writes two-rooms-cm.gltf and two-rooms-mm.gltf: two-rooms with every length
(vertex positions, node translations) in centimetres and in millimetres, for the scene-unit
tests (tests/cli/test_units.sh generates them; they are not committed). Loaded with
`--units cm` / `--units mm` they are two-rooms.gltf scaled back to metres.

Output is deterministic (same bytes on every run), so the files are committed and this script
regenerates them. Python 3 standard library only. tests/core/test_scene.cpp checks that the
committed files equal this script's output.

Conventions shared by all three scenes:
  * metres, +Y up, glTF 2.0;
  * every wall, floor, ceiling, pillar and piece of furniture is a closed box with thickness,
    single-sided, front faces pointing out of the solid (CCW seen from outside), so "inside
    geometry" is well defined (a point inside a solid box sees only back faces);
  * boxes touch but never overlap;
  * every mesh has per-face (flat) normals; one mesh and one node per box, named after it;
  * point / spot light intensities are radiant intensities in W/sr and directional light
    intensities irradiances in W/m^2 (ProbeStudio's reading of KHR_lights_punctual).

Scenes:
  cornell.gltf      the classic Cornell box at 5.5 m scale (555 mm x 10, rounded): interior
                    5.5 x 5.5 x 5.5 m, x in [-2.75, 2.75], y in [0, 5.5], z in [-2.75, 2.75],
                    open towards +z (the camera side). Red left wall (-x), green right wall (+x),
                    white floor, ceiling and back wall, a short and a tall white block (rotated
                    about +Y by node rotations) and an emissive ceiling panel (1.3 x 1.05 m,
                    2 cm thick, flush with the ceiling so its lower face is 2 cm below it) as the
                    only light. No KHR lights.
  pillar-room.gltf  one closed 8 x 3 x 8 m room with a 1.2 x 1.2 m pillar from floor to ceiling
                    in the middle and an off-centre point light near the ceiling.
  two-rooms.gltf    two 6 x 3 x 6 m rooms side by side joined by a 1 x 2.1 m doorway in a
                    0.1 m shared wall; room A (-x) lit by a warm point light, room B (+x) by a sun
                    shining through a window in its east wall onto its floor.
"""

import base64
import json
import math
import os
import struct
import sys

# ----------------------------------------------------------------------------- geometry


def box_mesh(lo, hi):
    """Positions, normals (per face) and u16 indices of the closed box [lo, hi].

    Face with outward normal +e_a uses in-plane axes u = a+1, v = a+2 (e_u x e_v = e_a); the
    face with normal -e_a swaps them, so every face is CCW seen from outside.
    """
    positions, normals, indices = [], [], []
    for axis in range(3):
        for sign in (-1, 1):
            u, v = (axis + 1) % 3, (axis + 2) % 3
            if sign < 0:
                u, v = v, u
            coord = hi[axis] if sign > 0 else lo[axis]
            base = len(positions)
            for cu, cv in ((lo[u], lo[v]), (hi[u], lo[v]), (hi[u], hi[v]), (lo[u], hi[v])):
                p = [0.0, 0.0, 0.0]
                p[axis], p[u], p[v] = coord, cu, cv
                positions.append(p)
                n = [0.0, 0.0, 0.0]
                n[axis] = float(sign)
                normals.append(n)
            indices += [base, base + 1, base + 2, base, base + 2, base + 3]
    return positions, normals, indices


def quat_axis_angle(axis, angle_rad):
    s = math.sin(angle_rad / 2)
    n = math.sqrt(sum(a * a for a in axis))
    return [axis[0] / n * s, axis[1] / n * s, axis[2] / n * s, math.cos(angle_rad / 2)]


def quat_from_minus_z_to(d):
    """Unit quaternion (x, y, z, w) rotating the local -Z axis onto the unit direction d."""
    n = math.sqrt(sum(c * c for c in d))
    d = [c / n for c in d]
    a = [0.0, 0.0, -1.0]
    c = [a[1] * d[2] - a[2] * d[1], a[2] * d[0] - a[0] * d[2], a[0] * d[1] - a[1] * d[0]]
    w = 1.0 + (a[0] * d[0] + a[1] * d[1] + a[2] * d[2])
    q = [c[0], c[1], c[2], w]
    qn = math.sqrt(sum(x * x for x in q))
    return [x / qn for x in q]


def r6(x):
    """Rounds for JSON so the text is stable and readable."""
    v = round(x, 6)
    return 0.0 if v == 0 else v


# ----------------------------------------------------------------------------- glTF writer


class GltfBuilder:
    def __init__(self, name, units_per_metre=1.0):
        self.name = name
        self.scale = units_per_metre  # every length written is multiplied by it
        self.blob = bytearray()
        self.doc = {
            "asset": {"version": "2.0", "generator": "ProbeStudio scripts/make_scenes.py"},
            "scene": 0,
            "scenes": [{"name": name, "nodes": []}],
            "nodes": [],
            "meshes": [],
            "materials": [],
            "accessors": [],
            "bufferViews": [],
            "buffers": [],
        }
        self.material_ids = {}
        self.lights = []
        self.extensions_used = set()

    def material(self, name, albedo, emissive=None, strength=None):
        m = {
            "name": name,
            "pbrMetallicRoughness": {
                "baseColorFactor": [r6(c) for c in albedo] + [1.0],
                "metallicFactor": 0.0,
                "roughnessFactor": 1.0,
            },
        }
        if emissive is not None:
            m["emissiveFactor"] = [r6(c) for c in emissive]
            if strength is not None:
                m["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": strength}}
                self.extensions_used.add("KHR_materials_emissive_strength")
        self.material_ids[name] = len(self.doc["materials"])
        self.doc["materials"].append(m)

    def _view(self, data, target):
        while len(self.blob) % 4:
            self.blob.append(0)
        view = {"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data), "target": target}
        self.blob += data
        self.doc["bufferViews"].append(view)
        return len(self.doc["bufferViews"]) - 1

    def _accessor(self, acc):
        self.doc["accessors"].append(acc)
        return len(self.doc["accessors"]) - 1

    def box(self, name, lo, hi, material, translation=None, rotation=None):
        """Adds one box mesh and one root node. lo/hi are in the node's local frame."""
        lo, hi = [x * self.scale for x in lo], [x * self.scale for x in hi]
        if translation is not None:
            translation = [t * self.scale for t in translation]
        positions, normals, indices = box_mesh(lo, hi)
        pdata = b"".join(struct.pack("<3f", *p) for p in positions)
        ndata = b"".join(struct.pack("<3f", *n) for n in normals)
        idata = struct.pack("<%dH" % len(indices), *indices)
        pmin = [min(p[i] for p in positions) for i in range(3)]
        pmax = [max(p[i] for p in positions) for i in range(3)]
        # Round-trip min/max through float32 so they equal the stored values exactly.
        f32 = lambda x: struct.unpack("<f", struct.pack("<f", x))[0]
        pos = self._accessor({
            "bufferView": self._view(pdata, 34962), "componentType": 5126,
            "count": len(positions), "type": "VEC3",
            "min": [r6(f32(x)) for x in pmin], "max": [r6(f32(x)) for x in pmax]})
        nor = self._accessor({
            "bufferView": self._view(ndata, 34962), "componentType": 5126,
            "count": len(normals), "type": "VEC3"})
        ind = self._accessor({
            "bufferView": self._view(idata, 34963), "componentType": 5123,
            "count": len(indices), "type": "SCALAR"})
        self.doc["meshes"].append({"name": name, "primitives": [{
            "attributes": {"POSITION": pos, "NORMAL": nor}, "indices": ind,
            "material": self.material_ids[material], "mode": 4}]})
        node = {"name": name, "mesh": len(self.doc["meshes"]) - 1}
        if rotation is not None:
            node["rotation"] = [r6(q) for q in rotation]
        if translation is not None:
            node["translation"] = [r6(t) for t in translation]
        self._add_root(node)

    def light(self, name, light, translation=None, rotation=None):
        self.extensions_used.add("KHR_lights_punctual")
        light = dict(light, name=name)
        if "range" in light:
            light["range"] = light["range"] * self.scale
        if translation is not None:
            translation = [t * self.scale for t in translation]
        self.lights.append(light)
        node = {"name": name,
                "extensions": {"KHR_lights_punctual": {"light": len(self.lights) - 1}}}
        if rotation is not None:
            node["rotation"] = [r6(q) for q in rotation]
        if translation is not None:
            node["translation"] = [r6(t) for t in translation]
        self._add_root(node)

    def _add_root(self, node):
        self.doc["nodes"].append(node)
        self.doc["scenes"][0]["nodes"].append(len(self.doc["nodes"]) - 1)

    def write(self, path):
        doc = dict(self.doc)
        if self.lights:
            doc["extensions"] = {"KHR_lights_punctual": {"lights": self.lights}}
        if self.extensions_used:
            doc["extensionsUsed"] = sorted(self.extensions_used)
        doc["buffers"] = [{
            "byteLength": len(self.blob),
            "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(self.blob)).decode("ascii"),
        }]
        with open(path, "w", encoding="utf-8", newline="\n") as f:
            json.dump(doc, f, indent=1, sort_keys=False)
            f.write("\n")


# ----------------------------------------------------------------------------- the scenes

WALL_T = 0.2  # outer wall, floor and ceiling thickness (m)


def room_shell(b, lo, hi, wall, floor, ceiling, t=WALL_T, prefix=""):
    """A closed room with interior [lo, hi]: floor and ceiling slabs spanning the outer extent,
    four walls between them (the x walls span the full outer z, the z walls fit in between)."""
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    b.box(prefix + "floor", [x0 - t, y0 - t, z0 - t], [x1 + t, y0, z1 + t], floor)
    b.box(prefix + "ceiling", [x0 - t, y1, z0 - t], [x1 + t, y1 + t, z1 + t], ceiling)
    b.box(prefix + "wall-north", [x0 - t, y0, z0 - t], [x1 + t, y1, z0], wall)
    b.box(prefix + "wall-south", [x0 - t, y0, z1], [x1 + t, y1, z1 + t], wall)
    b.box(prefix + "wall-west", [x0 - t, y0, z0], [x0, y1, z1], wall)
    b.box(prefix + "wall-east", [x1, y0, z0], [x1 + t, y1, z1], wall)


def cornell():
    b = GltfBuilder("cornell")
    b.material("white", [0.73, 0.73, 0.73])
    b.material("red", [0.63, 0.065, 0.05])
    b.material("green", [0.14, 0.45, 0.091])
    b.material("light", [0.78, 0.78, 0.78], emissive=[1.0, 1.0, 1.0], strength=16.0)
    h, s, t = 2.75, 5.5, 0.1
    # Floor and ceiling span the outer width; the back wall and the side walls stand between them.
    b.box("floor", [-h - t, -t, -h - t], [h + t, 0.0, h], "white")
    b.box("ceiling", [-h - t, s, -h - t], [h + t, s + t, h], "white")
    b.box("back-wall", [-h - t, 0.0, -h - t], [h + t, s, -h], "white")
    b.box("left-wall", [-h - t, 0.0, -h], [-h, s, h], "red")
    b.box("right-wall", [h, 0.0, -h], [h + t, s, h], "green")
    # Classic blocks: short 1.65 m cube front-right, tall 1.65 x 3.3 x 1.65 back-left.
    b.box("short-block", [-0.825, 0.0, -0.825], [0.825, 1.65, 0.825], "white",
          translation=[0.95, 0.0, 0.75], rotation=quat_axis_angle([0, 1, 0], math.radians(-17)))
    b.box("tall-block", [-0.825, 0.0, -0.825], [0.825, 3.3, 0.825], "white",
          translation=[-0.9, 0.0, -0.85], rotation=quat_axis_angle([0, 1, 0], math.radians(17)))
    # Emissive panel flush with the ceiling; its lower face, 2 cm below the ceiling, faces down.
    b.box("light-panel", [-0.65, s - 0.02, -0.525], [0.65, s, 0.525], "light")
    return b


def pillar_room():
    b = GltfBuilder("pillar-room")
    b.material("wall", [0.8, 0.8, 0.8])
    b.material("floor", [0.5, 0.45, 0.4])
    b.material("pillar", [0.7, 0.35, 0.25])
    room_shell(b, [-4.0, 0.0, -4.0], [4.0, 3.0, 4.0], "wall", "floor", "wall")
    b.box("pillar", [-0.6, 0.0, -0.6], [0.6, 3.0, 0.6], "pillar")
    # 30 W/sr: 4.1 W/m^2 on the floor straight below (2.7 m), ~0.3 W/m^2 in the far corner.
    b.light("ceiling-light", {"type": "point", "color": [1.0, 0.92, 0.8], "intensity": 30.0},
            translation=[2.0, 2.7, 1.5])
    return b


def two_rooms(units_per_metre=1.0):
    b = GltfBuilder("two-rooms", units_per_metre)
    b.material("wall", [0.8, 0.8, 0.8])
    b.material("floor-a", [0.55, 0.4, 0.3])
    b.material("floor-b", [0.45, 0.5, 0.55])
    b.material("furniture", [0.6, 0.5, 0.35])
    t, hw, h = WALL_T, 0.05, 3.0          # outer wall, half shared wall, ceiling height
    xa0, xb1, z0, z1 = -6.0 - hw, 6.0 + hw, -3.0, 3.0
    # Floor and ceiling per room, spanning to the outer faces and meeting under the shared wall.
    b.box("floor-a", [xa0 - t, -t, z0 - t], [0.0, 0.0, z1 + t], "floor-a")
    b.box("floor-b", [0.0, -t, z0 - t], [xb1 + t, 0.0, z1 + t], "floor-b")
    b.box("ceiling-a", [xa0 - t, h, z0 - t], [0.0, h + t, z1 + t], "wall")
    b.box("ceiling-b", [0.0, h, z0 - t], [xb1 + t, h + t, z1 + t], "wall")
    b.box("wall-north", [xa0 - t, 0.0, z0 - t], [xb1 + t, h, z0], "wall")
    b.box("wall-south", [xa0 - t, 0.0, z1], [xb1 + t, h, z1 + t], "wall")
    b.box("wall-west", [xa0 - t, 0.0, z0], [xa0, h, z1], "wall")
    # East wall of room B with a 1.6 x 1.2 m window (z in [-0.8, 0.8], y in [1.0, 2.2]).
    wz0, wz1, wy0, wy1 = -0.8, 0.8, 1.0, 2.2
    b.box("wall-east-north", [xb1, 0.0, z0], [xb1 + t, h, wz0], "wall")
    b.box("wall-east-south", [xb1, 0.0, wz1], [xb1 + t, h, z1], "wall")
    b.box("wall-east-sill", [xb1, 0.0, wz0], [xb1 + t, wy0, wz1], "wall")
    b.box("wall-east-lintel", [xb1, wy1, wz0], [xb1 + t, h, wz1], "wall")
    # Shared wall with a 1 x 2.1 m doorway (z in [-0.5, 0.5]).
    dz0, dz1, dy1 = -0.5, 0.5, 2.1
    b.box("shared-wall-north", [-hw, 0.0, z0], [hw, h, dz0], "wall")
    b.box("shared-wall-south", [-hw, 0.0, dz1], [hw, h, z1], "wall")
    b.box("shared-wall-lintel", [-hw, dy1, dz0], [hw, h, dz1], "wall")
    # Furniture: a low cabinet in room A, a table-sized block in room B away from the sun patch.
    b.box("cabinet-a", [-5.6, 0.0, -2.95], [-3.8, 0.9, -2.45], "furniture")
    b.box("block-b", [1.5, 0.0, 1.6], [2.7, 0.75, 2.4], "furniture")
    # Room A: warm point light near its ceiling, 15 W/sr (2.3 W/m^2 on the floor below).
    b.light("room-a-light", {"type": "point", "color": [1.0, 0.78, 0.55], "intensity": 15.0},
            translation=[-3.2, 2.55, 0.6])
    # Room B: a sun travelling along (-1, -0.8, 0.25): through the window (x = 6.05, y 1.0-2.2)
    # it lands on B's floor at x ~ 3.3-4.8, z ~ -0.5-1.5. Irradiance 4 W/m^2 facing the sun.
    b.light("sun", {"type": "directional", "color": [1.0, 0.96, 0.9], "intensity": 4.0},
            rotation=quat_from_minus_z_to([-1.0, -0.8, 0.25]))
    return b


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    args = [a for a in sys.argv[1:] if a != "--unit-copies"]
    out = args[0] if args else os.path.join(here, "..", "resources", "scenes")
    os.makedirs(out, exist_ok=True)
    scenes = [(cornell, "cornell"), (pillar_room, "pillar-room"), (two_rooms, "two-rooms")]
    if "--unit-copies" in sys.argv[1:]:
        scenes += [(lambda: two_rooms(100.0), "two-rooms-cm"), (lambda: two_rooms(1000.0), "two-rooms-mm")]
    for make, name in scenes:
        path = os.path.join(out, name + ".gltf")
        make().write(path)
        print("wrote", os.path.normpath(path))


if __name__ == "__main__":
    main()
