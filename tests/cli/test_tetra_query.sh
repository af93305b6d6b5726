#!/usr/bin/env bash
# `tetra` and `query` against known answers. tetra: the 8 corners of the unit cube plus its
# centre (and duplicates, and round-trip decimals) give exactly 12 tets of volume 1/12, each
# joining the centre to half a cube face, positively oriented, neighbours symmetric (i opposite
# vertex i), -1 on the 12 hull faces. query: a volume built from that mesh whose probes carry
# SH with a closed-form irradiance: channel r is a constant environment of radiance
# L(p) = 1 + x + 2y + 3z (irradiance pi L, linear in p, so barycentric interpolation is exact),
# channel g adds a band-1 term (irradiance pi + (2 pi / 3) 0.488603 k n_y), channel b is 0.5 pi.
# Usage: test_tetra_query.sh PROBESTUDIO REPO_ROOT
set -euo pipefail
cli="$1"
tmp="$(mktemp -d)"; trap 'rm -rf "$tmp"' EXIT

cat >"$tmp/pts.txt" <<'EOF'
# the cube's corners, its centre, a duplicate corner and a duplicate centre
0 0 0
1 0 0
0 1 0
1 1 0
0 0 1
1 0 1
0 1 1
1 1 1
0.5 0.5 0.5
1 1 1
0.5 0.5 0.5
EOF
"$cli" tetra "$tmp/pts.txt" -o "$tmp/tets.json" >/dev/null

# Round-trip precision: decimals with no short binary form come back bit-exact.
printf '0.1 0.2 0.3\n1.1 0.2 0.3\n0.1 1.7000000000000002 0.3\n0.1 0.2 2.9999999999999996\n1e-300 3.141592653589793 -2.718281828459045\n' >"$tmp/dec.txt"
"$cli" tetra "$tmp/dec.txt" -o "$tmp/dec.json" >/dev/null

python3 - "$tmp" <<'PY'
import json, sys
from fractions import Fraction as F
tmp = sys.argv[1]
t = json.load(open(f"{tmp}/tets.json"))
assert list(t) == ["vertex_of_input", "vertices", "tets", "neighbors"], list(t)
V, T, N = t["vertices"], t["tets"], t["neighbors"]
assert t["vertex_of_input"] == [0, 1, 2, 3, 4, 5, 6, 7, 8, 7, 8], t["vertex_of_input"]
assert V == [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1],
             [1, 1, 1], [0.5, 0.5, 0.5]], V
assert len(T) == 12 and len(N) == 12, (len(T), len(N))

def det(a, b, c, d):
    u = [F(b[i]) - F(a[i]) for i in range(3)]
    v = [F(c[i]) - F(a[i]) for i in range(3)]
    w = [F(d[i]) - F(a[i]) for i in range(3)]
    return (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
            + u[2] * (v[0] * w[1] - v[1] * w[0]))

hull = 0
for k, (tet, nb) in enumerate(zip(T, N)):
    assert 8 in tet, f"tet {k} {tet} misses the centre"
    assert det(*[V[i] for i in tet]) == F(6, 12), f"tet {k}: 6 x volume {det(*[V[i] for i in tet])}"
    for i in range(4):
        face = sorted(tet[:i] + tet[i + 1:])
        if nb[i] == -1:
            hull += 1
            assert 8 not in face, f"tet {k}: hull face {face} has the centre"
            continue
        j = N[nb[i]].index(k)
        other = T[nb[i]]
        assert sorted(other[:j] + other[j + 1:]) == face, (k, i, nb[i])
assert hull == 12, hull

d = json.load(open(f"{tmp}/dec.json"))
want = [[float(x) for x in line.split()] for line in open(f"{tmp}/dec.txt")]
assert d["vertices"] == want, (d["vertices"], want)
assert all(det(*[d["vertices"][i] for i in tet]) > 0 for tet in d["tets"])

# A volume (docs/formats.md, probe volume v1) on the cube mesh with closed-form SH.
import struct, zlib
k = 0.75
def sh(p):
    x, y, z = p
    L = 1 + x + 2 * y + 3 * z
    c = [[0.0, 0.0, 0.0] for _ in range(9)]
    c[0] = [L * 3.5449077018110318, 3.5449077018110318, 0.5 * 3.5449077018110318]  # 2 sqrt(pi)
    c[1][1] = k  # Y1,-1 = 0.488603 y
    return [v for coef in c for v in coef]

def inverse_rows(a, b, c):  # rows of [a b c]^-1 for column vectors a, b, c
    det3 = a[0] * (b[1] * c[2] - b[2] * c[1]) - b[0] * (a[1] * c[2] - a[2] * c[1]) \
        + c[0] * (a[1] * b[2] - a[2] * b[1])
    cross = lambda u, v: [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
    return [x / det3 for r in (cross(b, c), cross(c, a), cross(a, b)) for x in r]

mats = []
for tet in T:
    q = [V[i] for i in tet]
    col = [[q[j][a] - q[3][a] for a in range(3)] for j in range(3)]
    mats += inverse_rows(*col)
hullFaces = [(k2, i) for k2, nb in enumerate(N) for i in range(4) if nb[i] == -1]
P, Tn, H = len(V), len(T), len(hullFaces)
b = b"PSVOLUM1" + struct.pack("<6I", 1, 2, P, Tn, H, 2)
b += struct.pack(f"<{3 * P}f", *[x for v in V for x in v])
b += struct.pack(f"<{27 * P}f", *[x for v in V for x in sh(v)])
b += struct.pack(f"<{4 * Tn}i", *[i for tet in T for i in tet])
b += struct.pack(f"<{4 * Tn}i", *[i for nb in N for i in nb])
b += struct.pack(f"<{9 * Tn}f", *mats)
b += struct.pack(f"<{2 * H}i", *[x for f in hullFaces for x in f])
b += b"{}"
open(f"{tmp}/cube.psv", "wb").write(b + struct.pack("<I", zlib.crc32(b)))
PY

"$cli" query "$tmp/cube.psv" --at 0.25,0.5,0.5 --normal 0,1,0 --json >"$tmp/q1.json"
"$cli" query "$tmp/cube.psv" --at 0.5,0.5,0.5 --normal 0,0,1 --json >"$tmp/q2.json"
"$cli" query "$tmp/cube.psv" --at 3,0.5,0.25 --normal 0,-2,0 --json >"$tmp/q3.json"
printf '0.1 0.2 0.3\n0.9 0.8 0.7\n0.5 0.5 1\n-5 -5 -5\n0.5 2 0.5\n' >"$tmp/qp.txt"
printf '0 1 0\n0 -1 0\n1 0 0\n0 0 3\n0 1 0\n' >"$tmp/qn.txt"
"$cli" query "$tmp/cube.psv" --points "$tmp/qp.txt" --normals "$tmp/qn.txt" --json >"$tmp/q4.json"
"$cli" query "$tmp/cube.psv" --points "$tmp/qp.txt" --json >"$tmp/q5.json"

python3 - "$tmp" <<'PY'
import json, math, sys
tmp = sys.argv[1]
k = 0.75
def expected(p, n):
    x, y, z = (min(max(c, 0.0), 1.0) for c in p)  # clamped to the cube, the hull
    ny = n[1] / math.sqrt(sum(c * c for c in n))
    return [math.pi * (1 + x + 2 * y + 3 * z),
            math.pi + (2 * math.pi / 3) * 0.4886025119029199 * k * ny,
            0.5 * math.pi]

def check(q, p, n, outside):
    assert q["position"] == list(p), q
    assert q["outside"] is outside, q
    assert 0 <= q["tet"] < 12, q
    assert abs(sum(q["weights"]) - 1) < 1e-6 and all(-1e-7 <= w <= 1 + 1e-7 for w in q["weights"]), q
    want = expected(p, n)
    for got, w in zip(q["irradiance"], want):
        assert abs(got - w) <= 2e-5 * abs(w), (p, n, q["irradiance"], want)

q1 = json.load(open(f"{tmp}/q1.json"))
assert len(q1) == 1
check(q1[0], [0.25, 0.5, 0.5], [0, 1, 0], False)
q2 = json.load(open(f"{tmp}/q2.json"))[0]
check(q2, [0.5, 0.5, 0.5], [0, 0, 1], False)
assert max(q2["weights"]) > 1 - 1e-6, q2  # the centre probe alone
check(json.load(open(f"{tmp}/q3.json"))[0], [3, 0.5, 0.25], [0, -2, 0], True)
pts = [[float(c) for c in l.split()] for l in open(f"{tmp}/qp.txt")]
nrm = [[float(c) for c in l.split()] for l in open(f"{tmp}/qn.txt")]
q4 = json.load(open(f"{tmp}/q4.json"))
q5 = json.load(open(f"{tmp}/q5.json"))
assert len(q4) == len(q5) == 5
for i, (p, n) in enumerate(zip(pts, nrm)):
    out = any(c < 0 or c > 1 for c in p)
    check(q4[i], p, n, out)
    check(q5[i], p, [0, 1, 0], out)  # the default normal is +Y
print("tetra and query match the known answers")
PY

# Bad input: a normals file of the wrong length, a zero normal.
printf '0 1 0\n' >"$tmp/one.txt"
if "$cli" query "$tmp/cube.psv" --points "$tmp/qp.txt" --normals "$tmp/one.txt" --json 2>"$tmp/err"; then
  echo "a normals file of the wrong length was accepted"; exit 1
fi
grep -q "one.txt: has 1 normals for 5 points" "$tmp/err" || { cat "$tmp/err"; exit 1; }
if "$cli" query "$tmp/cube.psv" --at 0.5,0.5,0.5 --normal 0,0,0 --json 2>"$tmp/err"; then
  echo "a zero normal was accepted"; exit 1
fi
grep -q -- "--normal: 0,0,0 has zero length" "$tmp/err" || { cat "$tmp/err"; exit 1; }
printf '0 1 0\n0 1 0\n0 0 0\n0 1 0\n0 1 0\n' >"$tmp/zero.txt"
if "$cli" query "$tmp/cube.psv" --points "$tmp/qp.txt" --normals "$tmp/zero.txt" --json 2>"$tmp/err"; then
  echo "a zero normal in a file was accepted"; exit 1
fi
grep -q "zero.txt: normal 2: has zero length" "$tmp/err" || { cat "$tmp/err"; exit 1; }
echo "bad normals refused"
