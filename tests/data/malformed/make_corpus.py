#!/usr/bin/env python3
"""Writes the malformed-input corpus beside this script: probe sets (.json), volumes (.psv) and
glTF scenes (.gltf, .glb), each broken in one way. manifest.tsv (maintained by hand) gives the
message each must produce; tests/core/test_malformed.cpp loads every file and checks it.
Run from anywhere: python3 make_corpus.py"""
import base64, json, os, struct, zlib

HERE = os.path.dirname(os.path.abspath(__file__))


def write(name, data):
    mode = "wb" if isinstance(data, bytes) else "w"
    with open(os.path.join(HERE, name), mode) as f:
        f.write(data)


# ---- probe sets --------------------------------------------------------------------------
SH9 = [[0.5, 0.5, 0.5]] + [[0, 0, 0]] * 8


def probe_set(**over):
    s = {"format": "probestudio.probeset", "version": 2, "scene": "room.gltf",
         "scene_hash": "0123456789abcdef",
         "rig": {"sky_radiance": [1, 1, 1], "lights": []},
         "placement": {"method": "uniform", "spacing_m": 1, "budget": 0},
         "importance_volumes": [], "next_id": 3,
         "probes": [{"id": 1, "position": [0, 1, 0], "state": "accepted", "locked": False,
                     "method": "manual", "score": 0},
                    {"id": 2, "position": [1, 1, 0], "state": "candidate", "locked": False,
                     "method": "manual", "score": 0, "sh": SH9,
                     "sh_scene_hash": "0123456789abcdef"}]}
    s.update(over)
    return s


def probe(i, **over):
    p = dict(probe_set()["probes"][i])
    p.update(over)
    return p


def js(o):
    return json.dumps(o, indent=1)


write("ps-empty.json", "")
write("ps-truncated.json", js(probe_set())[:200])
write("ps-not-an-object.json", "[1, 2, 3]")
write("ps-wrong-format.json", js(probe_set(format="probestudio.volume")))
write("ps-future-version.json", js(probe_set(version=4)))
write("ps-bad-units.json", js(probe_set(version=3, units="furlong")))
write("ps-units-number.json", js(probe_set(version=3, units=0.001)))
write("ps-version-zero.json", js(probe_set(version=0)))
write("ps-version-string.json", js(probe_set(version="2")))
s = probe_set(); del s["probes"]; write("ps-missing-probes.json", js(s))
s = probe_set(); del s["scene_hash"]; write("ps-missing-scene-hash.json", js(s))
write("ps-probes-object.json", js(probe_set(probes={})))
write("ps-short-position.json", js(probe_set(probes=[probe(0), probe(1, position=[1, 2])])))
write("ps-position-strings.json", js(probe_set(probes=[probe(0, position=["1", "2", "3"])])))
write("ps-nan-literal.json", js(probe_set(probes=[probe(0, score="@")])).replace('"@"', "NaN"))
write("ps-overflow-number.json",
      js(probe_set(probes=[probe(0, position="@")])).replace('"@"', "[1e999, 1, 0]"))
write("ps-bad-state.json", js(probe_set(probes=[probe(0, state="maybe")])))
write("ps-duplicate-id.json", js(probe_set(probes=[probe(0), probe(1, id=1)])))
write("ps-negative-id.json", js(probe_set(probes=[probe(0, id=-4)])))
write("ps-fractional-id.json", js(probe_set(probes=[probe(0, id=1.5)])))
write("ps-sh-8-coefficients.json", js(probe_set(probes=[probe(1, sh=SH9[:8])])))
write("ps-bad-scene-hash.json", js(probe_set(scene_hash="not-a-hash")))
write("ps-importance-inverted.json", js(probe_set(importance_volumes=[
    {"name": "hall", "min": [0, 0, 0], "max": [1, -1, 1], "weight": 2}])))
write("ps-importance-negative-weight.json", js(probe_set(importance_volumes=[
    {"name": "hall", "min": [0, 0, 0], "max": [1, 1, 1], "weight": -2}])))
write("ps-light-type.json", js(probe_set(rig={"sky_radiance": [0, 0, 0], "lights": [
    {"type": "laser", "intensity": [1, 1, 1]}]})))
write("ps-zero-direction.json", js(probe_set(rig={"sky_radiance": [0, 0, 0], "lights": [
    {"type": "directional", "direction": [0, 0, 0], "intensity": [1, 1, 1]}]})))
write("ps-locked-string.json", js(probe_set(probes=[probe(0, locked="yes")])))

# ---- volumes -----------------------------------------------------------------------------


def volume(P=4, T=1, H=4, positions=None, tets=None, neighbors=None, order=2, version=1,
           magic=b"PSVOLUM1", fix_crc=True, counts=None, cut_start=None, cuts=None, maps=None):
    """Version 4 (visibility maps) when maps is given: (R, flags per probe, 2 R^2 P floats).
    Version 2 (the leak-cut section, read but never written) when cuts is given: a list of
    (nx, ny, nz, d, hide mask); with maps too, or with version=3, version 3."""
    positions = positions or [0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1][: 3 * P] + [0.5] * max(0, 3 * P - 12)
    tets = tets or [1, 2, 3, 0] * T
    neighbors = neighbors or [-1, -1, -1, -1] * T
    meta = b'{"scene":"room.gltf"}'
    c = counts or (P, T, H, len(meta))
    if maps is not None and (cuts is not None or version == 3):
        version = 3
        cuts = cuts or []
    elif maps is not None:
        version = 4 if version == 1 else version
    if cuts is not None:
        version = 2 if version == 1 else version
        cut_start = cut_start or [0] * T + [len(cuts)]
    b = magic + struct.pack("<6I", version, order, *c)
    if cuts is not None:
        b += struct.pack("<I", len(cuts))
    if maps is not None:
        b += struct.pack("<I", maps[0])
    b += struct.pack(f"<{3 * P}f", *positions)
    b += struct.pack(f"<{27 * P}f", *[0.01 * i for i in range(27 * P)])
    b += struct.pack(f"<{4 * T}i", *tets) + struct.pack(f"<{4 * T}i", *neighbors)
    b += struct.pack(f"<{9 * T}f", *([1, 0, 0, 0, 1, 0, 0, 0, 1] * T))
    b += struct.pack(f"<{2 * H}i", *sum(([0, k] for k in range(H)), []))
    if cuts is not None:
        b += struct.pack(f"<{len(cut_start)}I", *cut_start)
        for nx, ny, nz, d, hide in cuts:
            b += struct.pack("<4fI", nx, ny, nz, d, hide)
    if maps is not None:
        b += bytes(maps[1]) + struct.pack(f"<{len(maps[2])}f", *maps[2])
    b += meta
    return b + struct.pack("<I", zlib.crc32(b) if fix_crc else zlib.crc32(b) ^ 1)


good = volume()
write("vol-empty.psv", b"")
write("vol-magic-only.psv", b"PSVOLUM1")
write("vol-bad-magic.psv", b"PSVOLUM9" + good[8:])
write("vol-truncated.psv", good[: len(good) // 2])
write("vol-one-byte-short.psv", good[:-1])
write("vol-trailing-garbage.psv", good + b"\0\0\0\0")
write("vol-bad-crc.psv", volume(fix_crc=False))
write("vol-version-9.psv", volume(version=9))
write("vol-sh-order-3.psv", volume(order=3))
write("vol-huge-probe-count.psv", volume(counts=(0xFFFFFFFF, 1, 4, 21)))
write("vol-huge-tet-count.psv", volume(counts=(4, 0xFFFFFFFF, 4, 21)))
write("vol-huge-metadata.psv", volume(counts=(4, 1, 4, 0xFFFFFFFF)))
write("vol-nan-position.psv", volume(positions=[0, 0, 0, 1, 0, 0, 0, float("nan"), 0, 0, 0, 1]))
write("vol-inf-position.psv", volume(positions=[0, 0, 0, float("inf"), 0, 0, 0, 1, 0, 0, 0, 1]))
write("vol-tet-index.psv", volume(tets=[1, 2, 3, 4]))
write("vol-negative-tet-index.psv", volume(tets=[1, 2, -3, 0]))
write("vol-neighbor-index.psv", volume(neighbors=[-1, 7, -1, -1]))
write("vol-three-probes.psv", volume(P=3, tets=[1, 2, 0, 0]))
# Versions 2 and 3: the leak-cut section after the hull faces. Any cut plane is refused.
write("vol-cut-planes.psv", volume(cuts=[(1, 0, 0, 0.5, 1)]))
write("vol-cut-start-nonzero.psv", volume(cuts=[], cut_start=[0, 1]))
write("vol-cut-truncated.psv", volume(cuts=[(1, 0, 0, 0.5, 1)])[:-30])
write("vol-cut-header-truncated.psv", volume(cuts=[(1, 0, 0, 0.5, 1)])[:32])
# Version 4: 1x1 maps, mean and mean square of each probe's one texel.
maps1 = (1, [0, 0, 0, 1], sum(([0.5 + 0.25 * i, (0.5 + 0.25 * i) ** 2 + 0.01] for i in range(4)), []))
write("vol-vis-nan.psv", volume(maps=(1, maps1[1], maps1[2][:2] + [float("nan")] + maps1[2][3:])))
write("vol-vis-negative-variance.psv", volume(maps=(1, maps1[1], [3.0] + maps1[2][1:])))
write("vol-vis-negative-distance.psv", volume(maps=(1, maps1[1], [-0.5] + maps1[2][1:])))
write("vol-vis-size-0.psv", volume(maps=(0, maps1[1], [])))
write("vol-vis-size-65.psv", volume(maps=(65, maps1[1], maps1[2])))
write("vol-vis-wrong-size.psv", volume(maps=(2, maps1[1], maps1[2])))
write("vol-vis-truncated.psv", volume(maps=maps1)[:-30])
write("vol-vis-flag.psv", volume(maps=(1, [0, 2, 0, 0], maps1[2])))
write("vol-cut-planes-v3.psv", volume(maps=maps1, cuts=[(1, 0, 0, 0.5, 1)]))

# ---- glTF --------------------------------------------------------------------------------


def gltf(positions=(0, 0, 0, 1, 0, 0, 0, 1, 0), count=3, component=5126, acc_type="VEC3",
         byte_length=None, extra=None):
    data = struct.pack(f"<{len(positions)}f", *positions)
    g = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
         "nodes": [{"mesh": 0}], "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
         "buffers": [{"byteLength": len(data) if byte_length is None else byte_length,
                      "uri": "data:application/octet-stream;base64," +
                      base64.b64encode(data).decode()}],
         "bufferViews": [{"buffer": 0, "byteLength": len(data)}],
         "accessors": [{"bufferView": 0, "componentType": component, "count": count,
                        "type": acc_type}]}
    if extra:
        extra(g)
    return js(g)


write("gltf-empty.gltf", "")
write("gltf-not-json.gltf", "this is not a glTF file\n")
write("gltf-truncated.gltf", gltf()[:150])
write("gltf-huge-count.gltf", gltf(count=4000000000))
write("gltf-int-positions.gltf", gltf(component=5125))
write("gltf-vec2-positions.gltf", gltf(acc_type="VEC2"))
write("gltf-nan-position.gltf", gltf(positions=(0, 0, 0, 1, float("nan"), 0, 0, 1, 0)))
write("gltf-missing-accessor.gltf",
      gltf(extra=lambda g: g["meshes"][0]["primitives"][0]["attributes"].update(POSITION=7)))
write("glb-truncated.glb", struct.pack("<4sII", b"glTF", 2, 1 << 30) + b"\0" * 8)
write("glb-version-1.glb", struct.pack("<4sII", b"glTF", 1, 20) + b"\0" * 8)

# ---- well-formed seeds for the fuzz targets (tests/fuzz/seeds) ------------------------------
SEEDS = os.path.join(HERE, "..", "..", "fuzz", "seeds")
for sub in ("probeset", "volume", "gltf"):
    os.makedirs(os.path.join(SEEDS, sub), exist_ok=True)


def seed(sub, name, data):
    mode = "wb" if isinstance(data, bytes) else "w"
    with open(os.path.join(SEEDS, sub, name), mode) as f:
        f.write(data)


seed("probeset", "good.json", js(probe_set(importance_volumes=[
    {"name": "hall", "min": [0, 0, 0], "max": [1, 1, 1], "weight": 2}], rig={
    "sky_radiance": [0.1, 0.2, 0.3], "lights": [
        {"type": "directional", "name": "sun", "direction": [0, -1, 0], "intensity": [3, 3, 3]},
        {"type": "spot", "name": "s", "position": [0, 2, 0], "direction": [0, -1, 0],
         "intensity": [1, 1, 1], "range_m": 5, "inner_cone_rad": 0.3, "outer_cone_rad": 0.5}]})))
seed("probeset", "version1.json", js(dict((k, v) for k, v in probe_set(version=1).items()
                                          if k not in ("scene_hash", "importance_volumes"))))
seed("volume", "one-tet.psv", good)
seed("volume", "one-tet-cut.psv", volume(cuts=[(1, 0, 0, 0.25, 0x21)]))
seed("volume", "one-tet-visibility.psv", volume(maps=maps1, version=3))
seed("volume", "one-tet-visibility-v4.psv", volume(maps=maps1))
# Two tets sharing a face: positions 0..4, tets (1,2,3,0) and (1,3,2,4).
seed("volume", "two-tets.psv", volume(
    P=5, T=2, H=4, positions=[0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1],
    tets=[1, 2, 3, 0, 1, 3, 2, 4], neighbors=[-1, -1, -1, 1, -1, -1, -1, 0]))
seed("gltf", "triangle.gltf", gltf())
