#!/usr/bin/env python3
"""Writes a generated game level: a multi-storey office building as one glTF 2.0 file.

Usage: scripts/make_level.py [--preset full|small] [--width M] [--depth M] [--floors N]
                             [--seed N] [--lamps-per-room N] -o LEVEL.glb|LEVEL.gltf

Python 3 standard library only. The output is a function of the parameters alone: the same
parameters and seed give the same bytes on any machine (the random stream is this script's own
splitmix64, every length is a whole number of millimetres, the JSON's key order is fixed). A
`.glb` is one file; a `.gltf` is written with its buffer in a `.bin` of the same name beside it.
docs/levels.md describes the layout and the commands that measure on it.

The building (metres, +Y up; x along the width, z along the depth):
  * storeys of 3.5 m: a 0.3 m slab (a 0.28 m floor over a 0.02 m white ceiling) and 3.2 m of
    clear height; a roof slab on top. Outer walls 0.3 m thick, interior walls 0.1 m;
  * along z, modules of a room band, a 2.4 m corridor along x and a second room band; modules
    meet back to back across a thin wall. Each band is split along x into rooms 4 to 8 m wide
    (now and then a hall up to 20 m), each with a door to its corridor and sometimes one to its
    neighbour; rooms on an outer wall have windows (sill 0.9 m, head 2.3 m);
  * with more than one module, cross corridors at fixed x cut through every band; with more
    than one storey, switchback stairwells (two flights of 0.175 m steps and a landing) at fixed
    x in the first band, under an opening of the slab above;
  * furniture in every room: tables and desks with legs and chairs, shelves, cabinets, sofas,
    beds, rugs; kept clear of the doors and of each other;
  * light: a sun (a KHR_lights_punctual directional light, 6 W/m^2) entering the +z and +x
    facades' windows, point lights (W/sr, with a range) in corridors and in some rooms (or N in
    every room with --lamps-per-room N, the many-light benchmark), and a sky that glTF cannot
    carry: give it as the rig option printed at the end (`--env R,G,B`).

Every wall, slab, step and piece of furniture is a closed axis-aligned box, single-sided, faces
counter-clockwise seen from outside with outward flat normals, so a point inside any of them
sees back faces (the capture's validity test). Boxes touch but never overlap. Meshes group the
boxes by storey and material.
"""

import argparse
import array
import json
import os
import struct
import sys

from make_scenes import box_mesh

# ----------------------------------------------------------------------------- constants (mm)

STOREY = 3500         # floor-to-floor height
SLAB = 300            # slab thickness: floor on top, ceiling layer underneath
CEILING_LAYER = 20    # the slab's lower layer, ceiling material
OUTER = 300           # outer wall thickness
INNER = 100           # interior wall thickness
CORRIDOR = 2400       # corridor width between its walls
MIN_BAND = 4800       # least room-band depth (a stairwell needs 4.62 m)
MODULE_TARGET = 17000  # about one band + corridor + band
DOOR_HEIGHT = 2100
SILL, HEAD = 900, 2300  # window sill and head heights above the floor
ROOM_MIN, ROOM_MAX, HALL_MAX = 4000, 8000, 20000
STAIR_SLOT = 3000     # stairwell width between its walls (two 1.5 m flights)
CROSS_SLOT = 2400     # cross corridor width between its walls
RISE, TREAD, STEPS = 175, 280, 9  # per flight: 9 steps then the landing (or the next slab)
UPPER_LANDING = 1100
LIMITS = {"width": (12.0, 1000.0), "depth": (12.8, 400.0), "floors": (1, 20)}
SKY_RADIANCE = (0.2, 0.25, 0.35)  # W/m^2/sr, the rig option the level is meant to be lit with
SUN_DIRECTION = (-0.45, -0.55, -0.7)  # the direction the sun's light travels
SUN_IRRADIANCE = 6.0  # W/m^2 on a surface facing it

MATERIALS = [  # name, linear albedo
    ("exterior-wall", (0.55, 0.52, 0.48)),
    ("wall", (0.8, 0.78, 0.74)),
    ("floor", (0.45, 0.36, 0.28)),
    ("ceiling", (0.85, 0.85, 0.85)),
    ("stairs", (0.6, 0.6, 0.58)),
    ("wood", (0.5, 0.35, 0.2)),
    ("metal", (0.4, 0.4, 0.42)),
    ("white", (0.85, 0.84, 0.8)),
    ("fabric-red", (0.6, 0.2, 0.15)),
    ("fabric-blue", (0.2, 0.3, 0.55)),
    ("fabric-green", (0.25, 0.45, 0.2)),
]
FABRICS = ["fabric-red", "fabric-blue", "fabric-green"]


class ParameterError(Exception):
    pass


# ----------------------------------------------------------------------------- random stream


class Stream:
    """splitmix64: the same numbers on every Python version and platform."""

    def __init__(self, seed):
        self.state = (seed * 0x9E3779B97F4A7C15 + 0x632BE59BD9B4E019) & 0xFFFFFFFFFFFFFFFF

    def u64(self):
        self.state = (self.state + 0x9E3779B97F4A7C15) & 0xFFFFFFFFFFFFFFFF
        z = self.state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & 0xFFFFFFFFFFFFFFFF
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & 0xFFFFFFFFFFFFFFFF
        return z ^ (z >> 31)

    def randint(self, lo, hi):
        """An integer in [lo, hi]."""
        return lo + self.u64() % (hi - lo + 1)

    def chance(self, p):
        """True with probability p (to 1 in 2^53)."""
        return (self.u64() >> 11) < int(p * (1 << 53))

    def choice(self, items):
        return items[self.u64() % len(items)]


# ----------------------------------------------------------------------------- geometry


class Mesh:
    """Boxes of one material in one storey: flat-shaded, 24 vertices and 36 indices a box."""

    def __init__(self):
        self.positions = array.array("f")
        self.normals = array.array("f")
        self.indices = array.array("I")
        self.lo = [float("inf")] * 3
        self.hi = [float("-inf")] * 3

    def box(self, lo, hi):
        """The closed box [lo, hi] (mm), its faces CCW seen from outside (make_scenes.box_mesh)."""
        assert all(lo[a] < hi[a] for a in range(3)), (lo, hi)
        lo_m = [c / 1000.0 for c in lo]
        hi_m = [c / 1000.0 for c in hi]
        for a in range(3):
            self.lo[a] = min(self.lo[a], lo_m[a])
            self.hi[a] = max(self.hi[a], hi_m[a])
        positions, normals, indices = box_mesh(lo_m, hi_m)
        base = len(self.positions) // 3
        for p in positions:
            self.positions.extend(p)
        for n in normals:
            self.normals.extend(n)
        self.indices.extend(base + i for i in indices)

    def triangles(self):
        return len(self.indices) // 3


class Level:
    def __init__(self):
        self.meshes = {}  # (storey name, material) -> Mesh, in insertion order
        self.lights = []  # (name, KHR light dict, translation in m or None)
        self.rooms = 0
        self.stairwells = 0
        self.lamps_per_room = None  # None: a lamp in some rooms; N: N lamps in every room

    def box(self, group, material, lo, hi):
        key = (group, material)
        if key not in self.meshes:
            self.meshes[key] = Mesh()
        self.meshes[key].box(lo, hi)

    def point_light(self, name, pos_mm, intensity, colour, range_m):
        light = {"type": "point", "color": list(colour), "intensity": intensity, "range": range_m}
        self.lights.append((name, light, [c / 1000.0 for c in pos_mm]))

    def triangles(self):
        return sum(m.triangles() for m in self.meshes.values())


def wall_x(level, group, material, x0, x1, z0, z1, y0, y1, openings):
    """A wall along x over [x0, x1] x [y0, y1] x [z0, z1] with openings (ox0, ox1, oy0, oy1),
    sorted, disjoint and inside it: piers between them, a sill under and a lintel over each."""
    wall_along(level, group, material, 0, x0, x1, z0, z1, y0, y1, openings)


def wall_z(level, group, material, z0, z1, x0, x1, y0, y1, openings):
    """A wall along z; as wall_x with the axes swapped."""
    wall_along(level, group, material, 2, z0, z1, x0, x1, y0, y1, openings)


def wall_along(level, group, material, axis, a0, a1, c0, c1, y0, y1, openings):
    def put(s0, s1, h0, h1):
        if s1 <= s0 or h1 <= h0:
            return
        if axis == 0:
            level.box(group, material, (s0, h0, c0), (s1, h1, c1))
        else:
            level.box(group, material, (c0, h0, s0), (c1, h1, s1))

    at = a0
    for o0, o1, oy0, oy1 in sorted(openings):
        assert at <= o0 < o1 <= a1 and y0 <= oy0 < oy1 <= y1, (a0, a1, openings)
        put(at, o0, y0, y1)
        put(o0, o1, y0, oy0)
        put(o0, o1, oy1, y1)
        at = o1
    put(at, a1, y0, y1)


def slab_pieces(x0, x1, z0, z1, holes):
    """Rectangles covering [x0, x1] x [z0, z1] minus the disjoint holes (x0, x1, z0, z1)."""
    xs = sorted({x0, x1} | {h[0] for h in holes} | {h[1] for h in holes})
    out = []
    for a, b in zip(xs, xs[1:]):
        cut = sorted((h[2], h[3]) for h in holes if h[0] <= a and b <= h[1])
        at = z0
        for h0, h1 in cut:
            if h0 > at:
                out.append((a, b, at, h0))
            at = h1
        if at < z1:
            out.append((a, b, at, z1))
    return out


# ----------------------------------------------------------------------------- plan


class Plan:
    """The storey-independent layout: the z bands and corridors, the fixed x slots."""

    def __init__(self, width, depth, floors):
        self.W, self.D, self.floors = width, depth, floors
        inner = depth - 2 * OUTER
        modules = max(1, min((inner + INNER) // (MODULE_TARGET + INNER),
                             (inner + INNER) // (2 * MIN_BAND + 2 * INNER + CORRIDOR + INNER)))
        band = (inner - (modules - 1) * INNER - modules * (2 * INNER + CORRIDOR)) // (2 * modules)
        # Each entry: (kind, z0, z1) between walls; bands carry on which side their corridor is.
        self.bands, self.corridors, self.long_walls = [], [], []
        z = OUTER
        for m in range(modules):
            last = m == modules - 1
            b2 = band if not last else (depth - OUTER) - (z + band + 2 * INNER + CORRIDOR)
            w = len(self.long_walls)  # this module's walls: w, w + 1 and w + 2 after it
            self.bands.append({"z0": z, "z1": z + band, "corridor_side": +1, "outer": m == 0,
                               "index": len(self.bands), "corridor_wall": w,
                               "back_wall": None if m == 0 else w - 1})
            self.long_walls.append((z + band, z + band + INNER))
            cz = z + band + INNER
            self.corridors.append((cz, cz + CORRIDOR))
            self.long_walls.append((cz + CORRIDOR, cz + CORRIDOR + INNER))
            zb = cz + CORRIDOR + INNER
            self.bands.append({"z0": zb, "z1": zb + b2, "corridor_side": -1, "outer": last,
                               "index": len(self.bands), "corridor_wall": w + 1,
                               "back_wall": None if last else w + 2})
            z = zb + b2
            if not last:
                self.long_walls.append((z, z + INNER))
                z += INNER
        assert z == depth - OUTER
        self.modules = modules
        # Fixed slots along x: cross corridors through every band, stairwells in the first band.
        x0, x1 = OUTER, width - OUTER
        self.x0, self.x1 = x0, x1
        cross = [] if modules == 1 else ([0.5] if width < 100000 else [0.3, 0.7])
        stairs = [] if floors == 1 else [0.1] + ([0.9] if width >= 40000 else []) + \
            ([0.5] if width >= 120000 else [])
        self.cross = [self._slot(f, CROSS_SLOT) for f in cross]
        self.stairs = [self._slot(f, STAIR_SLOT) for f in stairs]

    def _slot(self, frac, size):
        """A slot of `size` centred at `frac` of the width, on a 100 mm grid, moved flush with
        an outer wall when it would leave less than a room's width there."""
        c = int(self.W * frac) // 100 * 100
        s0 = c - size // 2
        if s0 - INNER - self.x0 < ROOM_MIN:
            s0 = self.x0
        if self.x1 - (s0 + size) - INNER < ROOM_MIN:
            s0 = self.x1 - size
        return (s0, s0 + size)

    def band_slots(self, band, rng):
        """The slots of a band, west to east: dicts with kind room / cross / stair and x0, x1
        between their walls (a 0.1 m wall between neighbours)."""
        fixed = [(s, "cross") for s in self.cross]
        if band["index"] == 0:
            fixed += [(s, "stair") for s in self.stairs]
        fixed.sort()
        slots, at = [], self.x0
        for (s0, s1), kind in fixed:
            end = s0 - INNER if s0 > self.x0 else s0
            slots += [{"kind": "room", "x0": a, "x1": b} for a, b in split_rooms(at, end, rng)]
            slots.append({"kind": kind, "x0": s0, "x1": s1})
            at = s1 + INNER if s1 < self.x1 else s1
        slots += [{"kind": "room", "x0": a, "x1": b} for a, b in split_rooms(at, self.x1, rng)]
        return slots


def split_rooms(x0, x1, rng):
    """[x0, x1] (mm) split into rooms ROOM_MIN to ROOM_MAX wide (a hall up to HALL_MAX now and
    then) with a 0.1 m wall between neighbours, on a 100 mm grid where the ends allow."""
    out, at = [], x0
    while x1 - at > 0:
        left = x1 - at
        if left <= ROOM_MAX or (left <= HALL_MAX and rng.chance(0.5)):
            w = left
        else:
            hi = HALL_MAX if rng.chance(0.08) else ROOM_MAX
            w = rng.randint(ROOM_MIN // 100, min(hi, left - ROOM_MIN - INNER) // 100) * 100
        out.append((at, at + w))
        at += w + INNER
    return out


# ----------------------------------------------------------------------------- storeys


def build(width, depth, floors, seed, lamps_per_room=None):
    """The level for the parameters in mm (width, depth) and storeys; `lamps_per_room` None for
    lamps in some rooms, else that many lamps in every room."""
    rng = Stream(seed)
    plan = Plan(width, depth, floors)
    level = Level()
    level.lamps_per_room = lamps_per_room
    stair_holes = []
    for s0, s1 in plan.stairs:
        b = plan.bands[0]
        # The flights climb away from the corridor (+z side of band 0): the hole spans the
        # flights and the upper landing, the lower landing stays floor.
        stair_holes.append((s0, s1, b["z0"], b["z1"] - 1000))
    level.stairwells = len(plan.stairs)
    for f in range(floors):
        storey(level, plan, f, rng, stair_holes if f > 0 else [])
    # Roof.
    top = floors * STOREY
    level.box("roof", "ceiling", (0, top, 0), (width, top + CEILING_LAYER, depth))
    level.box("roof", "exterior-wall", (0, top + CEILING_LAYER, 0), (width, top + SLAB, depth))
    return level, plan


def storey(level, plan, f, rng, holes):
    """Storey f: its slab (less the stairwell `holes`, (x0, x1, z0, z1) in mm), its rooms,
    corridors, stairwells and walls, its lights."""
    g = "storey-%d" % f
    y = f * STOREY
    yf, yc = y + SLAB, (f + 1) * STOREY  # floor top, ceiling
    W, D = plan.W, plan.D
    for x0, x1, z0, z1 in slab_pieces(0, W, 0, D, holes):
        level.box(g, "ceiling", (x0, y, z0), (x1, y + CEILING_LAYER, z1))
        level.box(g, "floor", (x0, y + CEILING_LAYER, z0), (x1, yf, z1))
    band_slots = [plan.band_slots(b, rng) for b in plan.bands]
    # Openings per long wall (index into plan.long_walls) and per outer wall.
    long_open = [[] for _ in plan.long_walls]
    north, south, west, east = [], [], [], []
    ground = f == 0
    for band, slots in zip(plan.bands, band_slots):
        corridor_wall, back_wall = band["corridor_wall"], band["back_wall"]
        outer_list = None
        if band["outer"]:
            outer_list = north if band["corridor_side"] > 0 else south
        for k, s in enumerate(slots):
            x0, x1 = s["x0"], s["x1"]
            if s["kind"] == "cross":
                long_open[corridor_wall].append((x0, x1, yf, yf + 2600))
                if back_wall is not None:
                    long_open[back_wall].append((x0, x1, yf, yf + 2600))
                elif outer_list is not None:
                    top = yf + (DOOR_HEIGHT if ground else HEAD)
                    outer_list.append((x0 + 400, x1 - 400, yf if ground else yf + SILL, top))
                continue
            door = door_span(rng, x0, x1, 1800 if x1 - x0 >= 12000 else rng.choice([900, 1000, 1200]))
            long_open[corridor_wall].append((door[0], door[1], yf, yf + DOOR_HEIGHT))
            if outer_list is not None:
                outer_list.extend(windows(x0, x1, yf, rng))
            if x0 == plan.x0:
                west.extend(windows(band["z0"], band["z1"], yf, rng))
            if x1 == plan.x1:
                east.extend(windows(band["z0"], band["z1"], yf, rng))
            if s["kind"] == "stair":
                if f < plan.floors - 1:  # the top storey's stairwell is the opening only
                    stairwell(level, g, x0, x1, band["z0"], band["z1"], yf)
                continue
            level.rooms += 1
            room(level, plan, g, rng, band, s, door, slots, k, yf)
    # Corridor ends: a door on the ground floor, a window above.
    for cz0, cz1 in plan.corridors:
        for lst in (west, east):
            if ground:
                lst.append((cz0 + 400, cz1 - 400, yf, yf + DOOR_HEIGHT))
            else:
                lst.append((cz0 + 400, cz1 - 400, yf + SILL, yf + HEAD))
        corridor_lights(level, plan, g, cz0, cz1, yc)
    # Long walls, then the outer walls around them.
    for (z0, z1), openings in zip(plan.long_walls, long_open):
        # A cross corridor opens the wall between two bands from both sides: once.
        wall_x(level, g, "wall", plan.x0, plan.x1, z0, z1, yf, yc, sorted(set(openings)))
    wall_x(level, g, "exterior-wall", 0, W, 0, OUTER, yf, yc, north)
    wall_x(level, g, "exterior-wall", 0, W, D - OUTER, D, yf, yc, south)
    wall_z(level, g, "exterior-wall", OUTER, D - OUTER, 0, OUTER, yf, yc, west)
    wall_z(level, g, "exterior-wall", OUTER, D - OUTER, W - OUTER, W, yf, yc, east)
    # Walls between the slots of each band, with a door to the neighbour now and then.
    for band, slots in zip(plan.bands, band_slots):
        for a, b in zip(slots, slots[1:]):
            openings = []
            if a["kind"] == "room" and b["kind"] == "room" and a.get("side_door"):
                openings.append(a["side_door"])
            wall_z(level, g, "wall", band["z0"], band["z1"], a["x1"], b["x0"], yf, yc, openings)


def door_span(rng, x0, x1, w):
    """A door w wide somewhere in [x0 + 0.3, x1 - 0.3] m, on a 100 mm grid."""
    lo, hi = (x0 + 300) // 100, (x1 - 300 - w) // 100
    at = rng.randint(lo, hi) * 100 if hi >= lo else (x0 + x1 - w) // 2
    return (at, at + w)


def windows(a0, a1, yf, rng):
    """Windows along an outer wall's stretch [a0, a1] (mm): one per 3 m, evenly spaced."""
    n = max(1, (a1 - a0) // 3000)
    w = rng.choice([1200, 1500, 1800])
    step = (a1 - a0) // n
    out = []
    for i in range(n):
        c = a0 + step * i + step // 2
        out.append((c - w // 2, c + w // 2, yf + SILL, yf + HEAD))
    return out


def corridor_lights(level, plan, g, cz0, cz1, yc):
    """Point lights along a corridor every 50 m or so, 0.4 m under the ceiling."""
    n = max(1, (plan.x1 - plan.x0) // 50000)
    step = (plan.x1 - plan.x0) // n
    for i in range(n):
        x = plan.x0 + step * i + step // 2
        level.point_light("%s/corridor-light-%d-%d" % (g, cz0, i), (x, yc - 400, (cz0 + cz1) // 2),
                          6.0, (0.9, 0.95, 1.0), 14.0)


def stairwell(level, g, x0, x1, z0, z1, yf):
    """Switchback stairs from the floor at yf up one storey, in [x0, x1] x [z0, z1] (mm), the
    corridor on the +z side: a 1 m lower landing at +z, flight A climbing towards -z along the
    west half, the upper landing, flight B coming back along the east half to the slab above."""
    mid = (x0 + x1) // 2
    land = z1 - 1000 - STEPS * TREAD  # the upper landing spans [z0, land], at least 1.1 m
    assert land - z0 >= UPPER_LANDING
    for k in range(STEPS):  # flight A: step k rises (k + 1) risers, going -z from the bottom
        zs1 = z1 - 1000 - k * TREAD
        level.box(g, "stairs", (x0, yf, zs1 - TREAD), (mid, yf + (k + 1) * RISE, zs1))
    level.box(g, "stairs", (x0, yf, z0), (x1, yf + (STEPS + 1) * RISE, land))
    for j in range(STEPS):  # flight B: from the landing back towards +z
        zs0 = land + j * TREAD
        level.box(g, "stairs", (mid, yf, zs0), (x1, yf + (STEPS + 2 + j) * RISE, zs0 + TREAD))
    assert yf + (2 * STEPS + 1) * RISE < yf + STOREY  # the top step stays under the next floor


def room(level, plan, g, rng, band, slot, door, slots, k, yf):
    """Furniture, perhaps a lamp and a door to the next room for the room slots[k] (`slot`) of
    `band`, whose door to the corridor is `door` (x0, x1), on the floor at yf (mm)."""
    x0, x1, z0, z1 = slot["x0"], slot["x1"], band["z0"], band["z1"]
    side = band["corridor_side"]
    door_z = z1 if side > 0 else z0
    keep_out = [(door[0] - 300, door[1] + 300, door_z - 1300, door_z + 1300)]
    nxt = slots[k + 1] if k + 1 < len(slots) else None
    if nxt is not None and nxt["kind"] == "room" and rng.chance(0.3):
        a = rng.randint((z0 + 300) // 100, (z1 - 1300) // 100) * 100
        slot["side_door"] = (a, a + 1000, yf, yf + DOOR_HEIGHT)
        keep_out.append((x1 - 1300, x1 + 100, a - 300, a + 1300))
    prev = slots[k - 1] if k > 0 else None
    if prev is not None and prev.get("side_door"):
        a0, a1 = prev["side_door"][0], prev["side_door"][1]
        keep_out.append((x0 - 100, x0 + 1300, a0 - 300, a1 + 300))
    windowed = band["outer"] or x0 == plan.x0 or x1 == plan.x1
    furnish(level, g, rng, (x0, x1, z0, z1), keep_out, yf)
    # The draw is made either way, so that --lamps-per-room changes the lights and nothing else.
    lamp = rng.chance(0.02 if windowed else 0.08)
    n = level.lamps_per_room
    if n is None:
        if lamp:
            level.point_light("%s/room-light-%d-%d" % (g, x0, z0),
                              ((x0 + x1) // 2, yf + 2800, (z0 + z1) // 2), 10.0,
                              (1.0, 0.85, 0.65), 12.0)
        return
    for i in range(n):  # evenly along the room's width
        x = x0 + (x1 - x0) * (2 * i + 1) // (2 * n)
        level.point_light("%s/room-light-%d-%d-%d" % (g, x0, z0, i), (x, yf + 2800, (z0 + z1) // 2),
                          10.0, (1.0, 0.85, 0.65), 12.0)


def overlaps(a, b, gap):
    return a[0] < b[1] + gap and b[0] < a[1] + gap and a[2] < b[3] + gap and b[2] < a[3] + gap


def furnish(level, g, rng, rect, keep_out, yf):
    """Pieces of furniture in the room rect (x0, x1, z0, z1), 50 mm from the walls, 100 mm
    from each other, out of the keep-out rects: about one per 10 m^2, at most 8."""
    x0, x1, z0, z1 = rect
    area = (x1 - x0) * (z1 - z0) // 1000000
    want = max(1, min(8, area // 10))
    placed = list(keep_out)
    n = 0
    for _ in range(want * 8):
        if n >= want:
            break
        kind = rng.choice(["table", "table", "desk", "shelf", "cabinet", "sofa", "bed", "rug"])
        w, d = {"table": (1600, 900), "desk": (1400, 700), "shelf": (1200, 350),
                "cabinet": (1000, 500), "sofa": (2000, 900), "bed": (2000, 1600),
                "rug": (2400, 1700)}[kind]
        w += rng.randint(-2, 4) * 100
        turned = rng.chance(0.5)
        fx, fz = (d, w) if turned else (w, d)
        # Chairs around a table take 0.6 m on its long sides.
        pad = 600 if kind in ("table", "desk") else 0
        px, pz = (fx + 2 * pad, fz) if turned else (fx, fz + 2 * pad)
        if px > x1 - x0 - 100 or pz > z1 - z0 - 100:
            continue
        if kind in ("shelf", "cabinet", "sofa", "bed"):  # against a wall
            wall = rng.randint(0, 3)
            if wall == 0:
                fx0, fz0 = x0 + 50, rng.randint(z0 + 50, z1 - 50 - pz)
            elif wall == 1:
                fx0, fz0 = x1 - 50 - px, rng.randint(z0 + 50, z1 - 50 - pz)
            elif wall == 2:
                fx0, fz0 = rng.randint(x0 + 50, x1 - 50 - px), z0 + 50
            else:
                fx0, fz0 = rng.randint(x0 + 50, x1 - 50 - px), z1 - 50 - pz
        else:
            fx0 = rng.randint(x0 + 50, x1 - 50 - px)
            fz0 = rng.randint(z0 + 50, z1 - 50 - pz)
        fx0, fz0 = fx0 // 10 * 10, fz0 // 10 * 10
        foot = (fx0, fx0 + px, fz0, fz0 + pz)
        if any(overlaps(foot, o, 100) for o in placed):
            continue
        placed.append(foot)
        n += 1
        piece(level, g, rng, kind, foot, turned, pad, yf)


def piece(level, g, rng, kind, foot, turned, pad, y):
    """Boxes of one piece of furniture on the floor at y in footprint (x0, x1, z0, z1); a table's
    or desk's footprint includes `pad` on its long sides for chairs."""
    x0, x1, z0, z1 = foot
    if kind in ("table", "desk"):
        tx0, tx1, tz0, tz1 = (x0 + pad, x1 - pad, z0, z1) if turned else (x0, x1, z0 + pad, z1 - pad)
        mat = "wood" if kind == "table" else "white"
        level.box(g, mat, (tx0, y + 710, tz0), (tx1, y + 750, tz1))
        for lx, lz in ((tx0 + 30, tz0 + 30), (tx1 - 90, tz0 + 30), (tx0 + 30, tz1 - 90),
                       (tx1 - 90, tz1 - 90)):
            level.box(g, "metal", (lx, y, lz), (lx + 60, y + 710, lz + 60))
        # Chairs: seat, back and four legs, along both long sides.
        long = (tz1 - tz0) if turned else (tx1 - tx0)
        per_side = max(1, long // 700)
        fabric = rng.choice(FABRICS)
        for side in (-1, 1):
            for i in range(per_side):
                c = (long * (2 * i + 1)) // (2 * per_side)
                if turned:
                    cz = tz0 + c
                    cx = tx0 - 350 if side < 0 else tx1 + 350
                else:
                    cx = tx0 + c
                    cz = tz0 - 350 if side < 0 else tz1 + 350
                chair(level, g, fabric, cx, cz, y, side, turned)
    elif kind == "shelf":  # two sides, a back against the wall side, five boards; open front
        if turned:  # long along z, back at x0
            level.box(g, "wood", (x0, y, z0), (x1, y + 2000, z0 + 20))
            level.box(g, "wood", (x0, y, z1 - 20), (x1, y + 2000, z1))
            level.box(g, "wood", (x0, y, z0 + 20), (x0 + 20, y + 2000, z1 - 20))
            for k in range(5):
                level.box(g, "wood", (x0 + 20, y + k * 450, z0 + 20), (x1, y + k * 450 + 25, z1 - 20))
        else:  # long along x, back at z0
            level.box(g, "wood", (x0, y, z0), (x0 + 20, y + 2000, z1))
            level.box(g, "wood", (x1 - 20, y, z0), (x1, y + 2000, z1))
            level.box(g, "wood", (x0 + 20, y, z0), (x1 - 20, y + 2000, z0 + 20))
            for k in range(5):
                level.box(g, "wood", (x0 + 20, y + k * 450, z0 + 20), (x1 - 20, y + k * 450 + 25, z1))
    elif kind == "rug":
        level.box(g, rng.choice(FABRICS), (x0, y, z0), (x1, y + 10, z1))
    elif kind == "cabinet":
        level.box(g, rng.choice(["wood", "white", "metal"]), (x0, y, z0), (x1, y + 900, z1))
    elif kind == "sofa":
        fabric = rng.choice(FABRICS)
        level.box(g, fabric, (x0, y, z0), (x1, y + 420, z1))
        if turned:
            level.box(g, fabric, (x0, y + 420, z0), (x0 + 200, y + 850, z1))
        else:
            level.box(g, fabric, (x0, y + 420, z0), (x1, y + 850, z0 + 200))
    elif kind == "bed":
        level.box(g, "wood", (x0, y, z0), (x1, y + 350, z1))
        level.box(g, "white", (x0 + 50, y + 350, z0 + 50), (x1 - 50, y + 550, z1 - 50))
        if turned:  # long along z: the headboard at z0
            level.box(g, "wood", (x0, y + 350, z0), (x1, y + 1000, z0 + 50))
        else:  # long along x: the headboard at x0
            level.box(g, "wood", (x0, y + 350, z0 + 50), (x0 + 50, y + 1000, z1 - 50))


def chair(level, g, fabric, cx, cz, y, side, turned):
    """A 0.44 m chair centred at (cx, cz) facing the table (`side` -1: the table is at +): a
    seat block on the floor and a back."""
    h = 220
    level.box(g, fabric, (cx - h, y, cz - h), (cx + h, y + 460, cz + h))
    # The back on the side away from the table.
    if turned:
        bx = cx - h if side < 0 else cx + h - 40
        level.box(g, fabric, (bx, y + 460, cz - h), (bx + 40, y + 900, cz + h))
    else:
        bz = cz - h if side < 0 else cz + h - 40
        level.box(g, fabric, (cx - h, y + 460, bz), (cx + h, y + 900, bz + 40))


# ----------------------------------------------------------------------------- glTF writer


def f32(x):
    """x rounded to float32, as the buffer stores it."""
    return struct.unpack("<f", struct.pack("<f", x))[0]


def gltf_document(level):
    """The glTF JSON (a dict) and its binary buffer for the level."""
    blob = bytearray()
    doc = {
        "asset": {"version": "2.0", "generator": "ProbeStudio scripts/make_level.py"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": []}},
        "scene": 0,
        "scenes": [{"name": "level", "nodes": []}],
        "nodes": [],
        "meshes": [],
        "materials": [],
        "accessors": [],
        "bufferViews": [],
        "buffers": [],
    }
    material_ids = {}
    for mname, albedo in MATERIALS:
        material_ids[mname] = len(doc["materials"])
        doc["materials"].append({"name": mname, "pbrMetallicRoughness": {
            "baseColorFactor": list(albedo) + [1.0], "metallicFactor": 0.0,
            "roughnessFactor": 1.0}})

    def view(data, target):
        while len(blob) % 4:
            blob.append(0)
        doc["bufferViews"].append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data),
                                   "target": target})
        blob.extend(data)
        return len(doc["bufferViews"]) - 1

    def accessor(acc):
        doc["accessors"].append(acc)
        return len(doc["accessors"]) - 1

    def little(a):
        if sys.byteorder != "little":
            a = array.array(a.typecode, a)
            a.byteswap()
        return a.tobytes()

    def add_node(node):
        doc["nodes"].append(node)
        doc["scenes"][0]["nodes"].append(len(doc["nodes"]) - 1)

    for (group, mname), mesh in level.meshes.items():
        count = len(mesh.positions) // 3
        pos = accessor({"bufferView": view(little(mesh.positions), 34962), "componentType": 5126,
                        "count": count, "type": "VEC3", "min": [f32(c) for c in mesh.lo],
                        "max": [f32(c) for c in mesh.hi]})
        nor = accessor({"bufferView": view(little(mesh.normals), 34962), "componentType": 5126,
                        "count": count, "type": "VEC3"})
        ind = accessor({"bufferView": view(little(mesh.indices), 34963), "componentType": 5125,
                        "count": len(mesh.indices), "type": "SCALAR"})
        doc["meshes"].append({"name": group + "/" + mname, "primitives": [{
            "attributes": {"POSITION": pos, "NORMAL": nor}, "indices": ind,
            "material": material_ids[mname], "mode": 4}]})
        add_node({"name": group + "/" + mname, "mesh": len(doc["meshes"]) - 1})
    lights = doc["extensions"]["KHR_lights_punctual"]["lights"]
    sun = {"name": "sun", "type": "directional", "color": [1.0, 0.95, 0.85],
           "intensity": SUN_IRRADIANCE}
    lights.append(sun)
    add_node({"name": "sun", "rotation": quat_from_minus_z_to(SUN_DIRECTION),
              "extensions": {"KHR_lights_punctual": {"light": 0}}})
    for lname, light, translation in level.lights:
        lights.append(dict(light, name=lname))
        add_node({"name": lname, "translation": translation,
                  "extensions": {"KHR_lights_punctual": {"light": len(lights) - 1}}})
    return doc, bytes(blob)


def quat_from_minus_z_to(d):
    """Unit quaternion (x, y, z, w) turning the local -Z axis (a glTF light's) onto d."""
    n = sum(c * c for c in d) ** 0.5
    d = [c / n for c in d]
    q = [d[1], -d[0], 0.0, 1.0 - d[2]]  # (0, 0, -1) x d and 1 + (0, 0, -1) . d
    qn = sum(x * x for x in q) ** 0.5
    return [round(x / qn, 9) for x in q]


def write(level, path):
    """Writes .glb, or .gltf with a .bin of the same name beside it (the one name the bytes
    depend on: the buffer's uri); returns the bytes written."""
    doc, blob = gltf_document(level)
    if path.endswith(".glb"):
        doc["buffers"] = [{"byteLength": len(blob)}]
        text = json.dumps(doc, separators=(",", ":")).encode("utf-8")
        text += b" " * (-len(text) % 4)
        blob += b"\0" * (-len(blob) % 4)
        total = 12 + 8 + len(text) + 8 + len(blob)
        data = struct.pack("<III", 0x46546C67, 2, total)
        data += struct.pack("<II", len(text), 0x4E4F534A) + text
        data += struct.pack("<II", len(blob), 0x004E4942) + blob
        with open(path, "wb") as f:
            f.write(data)
        return len(data)
    bin_name = os.path.splitext(os.path.basename(path))[0] + ".bin"
    doc["buffers"] = [{"byteLength": len(blob), "uri": bin_name}]
    text = json.dumps(doc, separators=(",", ":")).encode("utf-8") + b"\n"
    with open(os.path.join(os.path.dirname(path), bin_name), "wb") as f:
        f.write(blob)
    with open(path, "wb") as f:
        f.write(text)
    return len(text) + len(blob)


# ----------------------------------------------------------------------------- command line

PRESETS = {"full": (200.0, 60.0, 4), "small": (26.0, 14.0, 1)}


def parse(argv):
    p = argparse.ArgumentParser(
        prog="make_level.py",
        description="Writes a generated multi-storey building as a glTF level (docs/levels.md).")
    p.add_argument("--preset", choices=sorted(PRESETS), default="full",
                   help="full: 200 x 60 m, 4 storeys (the benchmark level); small: 26 x 14 m, one "
                        "storey of about 6 rooms (the tests' level). Default full")
    p.add_argument("--width", type=float, help="building size along x in metres (12 to 1000)")
    p.add_argument("--depth", type=float, help="building size along z in metres (12.8 to 400)")
    p.add_argument("--floors", type=int, help="storeys (1 to 20)")
    p.add_argument("--seed", type=int, default=1, help="random seed, 0 or more (default 1)")
    p.add_argument("--lamps-per-room", type=int, metavar="N",
                   help="N lamps in every room (0 to 16) instead of one in some rooms; the "
                        "building is the same (the many-light benchmark)")
    p.add_argument("-o", "--output", required=True, help="level to write: .glb or .gltf (+ .bin)")
    a = p.parse_args(argv)
    width, depth, floors = PRESETS[a.preset]
    width = a.width if a.width is not None else width
    depth = a.depth if a.depth is not None else depth
    floors = a.floors if a.floors is not None else floors
    for flag, value in (("width", width), ("depth", depth), ("floors", floors)):
        lo, hi = LIMITS[flag]
        if not (lo <= value <= hi):  # also refuses nan
            raise ParameterError("--%s: expected %g to %g%s, got %g" % (
                flag, lo, hi, "" if flag == "floors" else " m", value))
    if a.lamps_per_room is not None and not (0 <= a.lamps_per_room <= 16):
        raise ParameterError("--lamps-per-room: expected 0 to 16, got %d" % a.lamps_per_room)
    if a.seed < 0 or a.seed >= 1 << 63:
        raise ParameterError("--seed: expected 0 to 2^63 - 1, got %d" % a.seed)
    if not (a.output.endswith(".glb") or a.output.endswith(".gltf")):
        raise ParameterError("--output: expected a .glb or .gltf file name, got \"%s\"" % a.output)
    folder = os.path.dirname(a.output) or "."
    if not os.path.isdir(folder):
        raise ParameterError("--output: the folder \"%s\" does not exist" % folder)
    return (int(round(width * 1000)), int(round(depth * 1000)), floors, a.seed, a.lamps_per_room,
            a.output)


def main(argv):
    try:
        width, depth, floors, seed, lamps, out = parse(argv)
    except ParameterError as e:
        sys.stderr.write("make_level.py: error: %s\n" % e)
        return 1
    level, plan = build(width, depth, floors, seed, lamps)
    size = write(level, out)
    print("wrote %s: %g x %g m, %g m high, %d storeys, %d rooms, %d stairwells, %d triangles, "
          "%d point lights and a sun, %d bytes" % (
              out, width / 1000, depth / 1000, (floors * STOREY + SLAB) / 1000, floors,
              level.rooms, level.stairwells, level.triangles(), len(level.lights), size))
    print("sky: --env %g,%g,%g" % SKY_RADIANCE)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
