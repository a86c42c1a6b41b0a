#!/usr/bin/python3
"""The aluminium fiducials of an nvstim scene, as scene points for a fusion consumer.

Reads a scene file (TOML: [layers] maps OBJ groups to materials, [[object]] places meshes) and its
meshes, takes the triangles of the fiducial layer (default face_al_panel, material
polished_aluminum: the thesis's aluminium targets), groups them into separate targets and writes
each target's centroid (ENU metres, the scene's frame) as a JSON list of {"name", "xyz_m"}, the
input of nvstim_fusion_reference.py --fiducials. It also prints where the targets stand against
the plane z = Z0 of the rig's ground homography: a target above that plane does not register
exactly through it (parallax of its height over the rig's baseline).

Usage: rit_fiducials.py [SCENE.toml] [-o FILE] [--layer NAME] [--ground-z-m Z0] [--gap-m G]
       default scene: scenarios/rit/scene_lamp_lit.toml beside this repository's examples/.
"""
import argparse
import json
import math
import os
import sys
import tomllib

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_SCENE = os.path.join(HERE, "..", "..", "scenarios", "rit", "scene_lamp_lit.toml")


def read_obj(path):
    """Vertices and faces (with their group) of an OBJ file; polygons fanned into triangles."""
    verts, tris, group = [], [], None
    with open(path, encoding="utf-8") as f:
        for line in f:
            parts = line.split()
            if not parts:
                continue
            if parts[0] == "v":
                verts.append(tuple(float(x) for x in parts[1:4]))
            elif parts[0] in ("g", "o"):
                group = parts[1] if len(parts) > 1 else None
            elif parts[0] == "f":
                idx = []
                for p in parts[1:]:
                    i = int(p.split("/")[0])
                    idx.append(i - 1 if i > 0 else len(verts) + i)  # OBJ: 1-based or relative
                for j in range(1, len(idx) - 1):
                    tris.append(((verts[idx[0]], verts[idx[j]], verts[idx[j + 1]]), group))
    return tris


def place(p, position_m, yaw_deg):
    """Object frame to scene frame: yaw turns the object's +y toward east (docs/scene.md), then
    the object's position is added."""
    a = math.radians(yaw_deg)
    x, y, z = p
    return (x * math.cos(a) + y * math.sin(a) + position_m[0],
            -x * math.sin(a) + y * math.cos(a) + position_m[1], z + position_m[2])


def tri_area_centroid(t):
    (ax, ay, az), (bx, by, bz), (cx, cy, cz) = t
    ux, uy, uz = bx - ax, by - ay, bz - az
    vx, vy, vz = cx - ax, cy - ay, cz - az
    nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    area = 0.5 * math.sqrt(nx * nx + ny * ny + nz * nz)
    return area, ((ax + bx + cx) / 3, (ay + by + cy) / 3, (az + bz + cz) / 3)


def cluster(tris, gap_m):
    """Single-linkage groups of triangles whose bounding boxes come within gap_m of each other:
    the faces of one target touch or interpenetrate; separate targets are metres apart."""
    boxes = [(tuple(min(v[i] for v in t) for i in range(3)), tuple(max(v[i] for v in t)
                                                                    for i in range(3)))
             for t in tris]
    parent = list(range(len(tris)))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i in range(len(tris)):
        for j in range(i + 1, len(tris)):
            (lo1, hi1), (lo2, hi2) = boxes[i], boxes[j]
            if all(lo1[k] - gap_m <= hi2[k] and lo2[k] - gap_m <= hi1[k] for k in range(3)):
                parent[root(i)] = root(j)
    groups = {}
    for i in range(len(tris)):
        groups.setdefault(root(i), []).append(tris[i])
    return list(groups.values())


def compass_name(x, y, taken):
    """A target's name from its bearing about the scene's origin (al_NE, ...), numbered if two
    share one."""
    sector = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")[
        int(((math.degrees(math.atan2(x, y)) + 22.5) % 360) // 45)]
    name, n = f"al_{sector}", 2
    while name in taken:
        name, n = f"al_{sector}{n}", n + 1
    taken.add(name)
    return name


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene", nargs="?", default=DEFAULT_SCENE)
    ap.add_argument("-o", "--output", help="write the JSON list here (default: standard output)")
    ap.add_argument("--layer", default="face_al_panel", help="the fiducials' OBJ group")
    ap.add_argument("--ground-z-m", type=float, default=0.0,
                    help="the plane of the rig's ground homography (rig ground_z_m)")
    ap.add_argument("--gap-m", type=float, default=0.25,
                    help="faces closer than this belong to one target")
    args = ap.parse_args(argv)
    # The report goes where the JSON does not.
    log = sys.stdout if args.output else sys.stderr

    try:
        with open(args.scene, "rb") as f:
            scene = tomllib.load(f)
    except (OSError, tomllib.TOMLDecodeError) as e:
        print(f"rit_fiducials: {args.scene}: {e}", file=sys.stderr)
        return 2
    layers = scene.get("layers", {})
    material = layers.get(args.layer)
    if material is None:
        print(f"rit_fiducials: {args.scene}: no layer {args.layer} in [layers]", file=sys.stderr)
        return 2
    # Other layers of the same material (the truck's wheel rims are polished aluminium too) are
    # not targets: they belong to a tracked object, not to fixed points of the scene.
    others = sorted(k for k, v in layers.items() if v == material and k != args.layer)

    base = os.path.dirname(os.path.abspath(args.scene))
    tris, elsewhere = [], {}
    for obj in scene.get("object", []):
        mesh = os.path.join(base, obj["mesh"])
        pos = obj.get("position_m", [0.0, 0.0, 0.0])
        yaw = obj.get("yaw_deg", 0.0)
        faces = read_obj(mesh)
        if "trajectory" in obj and any(group == args.layer for _, group in faces):
            print(f"rit_fiducials: object {obj['name']} moves (trajectory): its {args.layer} "
                  f"faces are placed at its static position", file=sys.stderr)
        for t, group in faces:
            mat = layers.get(group) if group in layers else obj.get("material")
            if group == args.layer:
                tris.append(tuple(place(v, pos, yaw) for v in t))
            elif mat == material:
                elsewhere[(obj["name"], group)] = elsewhere.get((obj["name"], group), 0) + 1
    if not tris:
        print(f"rit_fiducials: {args.scene}: no faces of layer {args.layer}", file=sys.stderr)
        return 2

    def north_then_west(group):  # a stable order: northernmost first, then westernmost
        return (-max(v[1] for t in group for v in t), min(v[0] for t in group for v in t))

    targets, taken = [], set()
    for faces in sorted(cluster(tris, args.gap_m), key=north_then_west):
        area_m2, sx, sy, sz = 0.0, 0.0, 0.0, 0.0
        for t in faces:
            a, c = tri_area_centroid(t)
            area_m2 += a
            sx, sy, sz = sx + a * c[0], sy + a * c[1], sz + a * c[2]
        # The area-weighted centroid of the target's surface: for a closed box the centre of its
        # volume; for the crossed plates, halfway between the two plates' centres.
        cx, cy, cz = sx / area_m2, sy / area_m2, sz / area_m2
        zs = [v[2] for t in faces for v in t]
        xs = [v[0] for t in faces for v in t]
        ys = [v[1] for t in faces for v in t]
        targets.append({"name": compass_name(cx, cy, taken),
                        "xyz_m": [round(cx, 4), round(cy, 4), round(cz, 4)],
                        "_faces": len(faces), "_area_m2": area_m2,
                        "_z": (min(zs), max(zs)), "_x": (min(xs), max(xs)),
                        "_y": (min(ys), max(ys))})

    z0 = args.ground_z_m
    print(f"{args.scene}: layer {args.layer} (material {material}): {len(tris)} triangles, "
          f"{len(targets)} targets", file=log)
    for t in targets:
        x, y, z = t["xyz_m"]
        zlo, zhi = t["_z"]
        print(f"  {t['name']:>6}: centroid ({x:+8.4f}, {y:+8.4f}, {z:+.4f}) m; {t['_faces']} "
              f"triangles, {t['_area_m2']:.3f} m2; extent x {t['_x'][0]:+.3f}..{t['_x'][1]:+.3f}, "
              f"y {t['_y'][0]:+.3f}..{t['_y'][1]:+.3f}, z {zlo:+.3f}..{zhi:+.3f} m", file=log)
    on_plane = all(abs(t["xyz_m"][2] - z0) < 1e-3 and t["_z"][1] - t["_z"][0] < 1e-3
                   for t in targets)
    if on_plane:
        print(f"  all on the plane z = {z0:g} m of the ground homography", file=log)
    else:
        zc = sorted({t["xyz_m"][2] for t in targets})
        zr = (min(t["_z"][0] for t in targets), max(t["_z"][1] for t in targets))
        print(f"  NOT on the plane z = {z0:g} m: they stand on it, z {zr[0]:.3f}..{zr[1]:.3f} m, "
              f"centroids at z = {', '.join(f'{z:.3f}' for z in zc)} m. Through the ground "
              f"homography a point h above the plane lands off its image by the parallax of h "
              f"over the baseline, about f_px * b_m * h_m / (Z_m^2 * sin(depression of the ray)) "
              f"(rit-fusion: 0.15 m baseline, 22-30 m range: about 0.1 px); the consumer "
              f"reports it per target as parallax_px.", file=log)
    if others or elsewhere:
        ex = ", ".join(f"{o}/{g}: {n} triangles" for (o, g), n in sorted(elsewhere.items()))
        print(f"  not targets, though of the same material: layer(s) {', '.join(others)}"
              f"{' (' + ex + ')' if ex else ''}", file=log)

    out = [{"name": t["name"], "xyz_m": t["xyz_m"]} for t in targets]
    text = json.dumps(out, indent=1) + "\n"
    if args.output:
        with open(args.output, "w", encoding="utf-8") as f:
            f.write(text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
