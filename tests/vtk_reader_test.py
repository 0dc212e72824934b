#!/usr/bin/python3
"""Reads `dem run`'s VTK output back with VTK's own reader and checks it against independent facts.

Usage: vtk_reader_test.py <dem program> <scene> <work folder>

Runs the scene twice, with binary (the default) and with ASCII VTK files, reads every particle and
contact snapshot with vtkXMLPolyDataReader (Debian's python3-vtk9) and fails, saying what differs, unless
  - ids are a permutation of 0..N-1, radii and materials are the scene's and the material names are its
    materials in order;
  - positions and velocities equal the same run's trajectories.csv rows of the snapshot's time, bit for bit;
  - each particle's coordination is the number of contact lines that name it, and every line runs
    between its particles' centres (a wall line from the centre to the contact point, a radius less half
    the overlap away), a pair's overlap being the radii's sum less the centres' distance;
  - each particle's force is the sum of the forces of its contact lines (normal and tangential, the
    second particle of a pair taking the negative), within round-off; the normal part lies along the
    line and the tangential part across it;
  - the stack placed at its equilibrium overlaps stays at rest: the upper sphere's contact carries m g and
    the lower one's plane contact 2 m g, and the force on each balances its weight, within round-off;
  - the binary and the ASCII run give the same values, bit for bit.
Run by ctest as vtk_reader_test; it must be Debian's python3 (/usr/bin/python3), which sees python3-vtk9.
"""
import csv
import math
import os
import shutil
import subprocess
import sys
import tomllib
import xml.etree.ElementTree as ET

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOXML import vtkXMLPolyDataReader

failures = []


def check(condition, message):
    if not condition:
        failures.append(message)
    return condition


def run(dem, scene, out, extra):
    shutil.rmtree(out, ignore_errors=True)
    subprocess.run([dem, "run", scene, "--out", out, "--quiet"] + extra, check=True)


def pvd_entries(path):
    root = ET.parse(path).getroot()
    return [(float(d.get("timestep")), d.get("file")) for d in root.iter("DataSet")]


def read_vtp(path):
    reader = vtkXMLPolyDataReader()
    reader.SetFileName(path)
    reader.Update()
    if reader.GetErrorCode() != 0:
        raise RuntimeError(f"{path}: VTK reader error {reader.GetErrorCode()}")
    data = reader.GetOutput()
    arrays = {}
    for attributes in (data.GetPointData(), data.GetCellData()):
        for k in range(attributes.GetNumberOfArrays()):
            array = attributes.GetArray(k)
            arrays[array.GetName()] = vtk_to_numpy(array).copy()
    points = data.GetPoints()
    arrays["points"] = vtk_to_numpy(points.GetData()).copy() if points is not None else np.zeros((0, 3))
    names = data.GetFieldData().GetAbstractArray("material_names")
    arrays["material_names"] = [names.GetValue(k) for k in range(names.GetNumberOfValues())] if names else []
    lines = data.GetLines()
    arrays["line_count"] = lines.GetNumberOfCells()
    return arrays


def read_run(out):
    particles = [(t, read_vtp(os.path.join(out, f))) for t, f in pvd_entries(os.path.join(out, "particles.pvd"))]
    contacts = [(t, read_vtp(os.path.join(out, f))) for t, f in pvd_entries(os.path.join(out, "contacts.pvd"))]
    return particles, contacts


def trajectories(out):
    rows = {}
    with open(os.path.join(out, "trajectories.csv")) as f:
        for row in csv.DictReader(f):
            rows.setdefault(float(row["time"]), {})[int(row["id"])] = row
    return rows


def check_run(label, out, scene):
    particles_spec = scene["particles"]
    material_names = [m["name"] for m in scene["materials"]]
    gravity = np.array(scene["scene"]["gravity"])
    n = len(particles_spec)
    rows = trajectories(out)
    particles, contacts = read_run(out)
    check(len(particles) >= 10, f"{label}: only {len(particles)} particle snapshots")
    check([t for t, _ in particles] == [t for t, _ in contacts], f"{label}: particle and contact snapshot times differ")
    tangential_seen = False
    for (t, p), (_, c) in zip(particles, contacts):
        where = f"{label} t={t!r}"
        ids = p["id"].astype(np.int64)
        if not check(sorted(ids.tolist()) == list(range(n)),
              f"{where}: ids {ids.tolist()} not a permutation of 0..{n - 1}"):
            continue
        slot = {int(i): k for k, i in enumerate(ids)}
        check(p["material_names"] == material_names,
              f"{where}: material_names {p['material_names']} != {material_names}")
        row = rows.get(t)
        check(row is not None, f"{where}: no trajectories.csv rows at this time")
        for i, spec in enumerate(particles_spec):
            k = slot[i]
            check(p["radius"][k] == spec["radius"], f"{where}: radius of {i} {p['radius'][k]!r} != {spec['radius']!r}")
            check(material_names[p["material"][k]] == spec["material"], f"{where}: material of {i}")
            if row is not None:
                r = row[i]
                for axis, name in enumerate("xyz"):
                    check(p["points"][k][axis] == float(r[name]),
                          f"{where}: position {name} of {i} differs from trajectories.csv")
                    check(p["velocity"][k][axis] == float(r["v" + name]), f"{where}: velocity {name} of {i} differs")
        # Contact lines: ends, coordination, forces.
        m = len(c["id_a"])
        check(c["line_count"] == m, f"{where}: {c['line_count']} lines for {m} contacts")
        coordination = np.zeros(n, dtype=np.int64)
        contact_force = np.zeros((n, 3))
        normal_sum = np.zeros(n)
        for e in range(m):
            a, b, wall = int(c["id_a"][e]), int(c["id_b"][e]), int(c["wall"][e])
            fn, ft = c["normal_force_vector"][e], c["tangential_force_vector"][e]
            start, end = c["points"][2 * e], c["points"][2 * e + 1]
            check(np.array_equal(start, p["points"][slot[a]]), f"{where}: contact {e} does not start at particle {a}")
            coordination[a] += 1
            contact_force[a] += fn + ft
            normal_sum[a] += c["normal_force"][e]
            if b >= 0:
                check(wall == -1, f"{where}: pair contact {e} names wall {wall}")
                check(np.array_equal(end, p["points"][slot[b]]), f"{where}: contact {e} does not end at particle {b}")
                coordination[b] += 1
                contact_force[b] -= fn + ft
                normal_sum[b] += c["normal_force"][e]
                reach = p["radius"][slot[a]] + p["radius"][slot[b]] - np.linalg.norm(start - end)
            else:
                check(wall >= 0, f"{where}: wall contact {e} names no wall")
                reach = 2 * (p["radius"][slot[a]] - np.linalg.norm(start - end))
            check(abs(reach - c["overlap"][e]) <= 1e-12,
                  f"{where}: overlap of contact {e} {c['overlap'][e]!r} != {reach!r}")
            direction = (start - end) / np.linalg.norm(start - end)
            check(abs(np.dot(fn, direction) - c["normal_force"][e]) <= 1e-12 * (1 + abs(c["normal_force"][e])) and
                  np.linalg.norm(np.cross(fn, direction)) <= 1e-12 * (1 + np.linalg.norm(fn)),
                  f"{where}: normal force of contact {e} not along its line")
            check(abs(np.dot(ft, direction)) <= 1e-12 * (1 + np.linalg.norm(ft)),
                  f"{where}: tangential force of contact {e} not across its line")
            tangential_seen |= np.linalg.norm(ft) > 1e-6
        for i, spec in enumerate(particles_spec):
            k = slot[i]
            check(p["coordination"][k] == coordination[i],
                  f"{where}: coordination of {i} is {p['coordination'][k]}, {coordination[i]} contact lines name it")
            expected = contact_force[i]
            check(np.linalg.norm(p["force"][k] - expected) <= 1e-9 * (1 + np.linalg.norm(expected)),
                  f"{where}: force of {i} {p['force'][k].tolist()} != the sum of its contact forces "
                  f"{expected.tolist()}")
        # The stack at rest: 0 carries 1 and itself on the plane, 1 rests on 0.
        weight = particles_spec[1]["mass"] * abs(gravity[2])
        check(coordination[0] == 2 and coordination[1] == 1,
              f"{where}: stack coordinations {coordination[:2].tolist()} != [2, 1]")
        check(abs(normal_sum[1] - weight) <= 1e-9 * weight,
              f"{where}: normal force on the upper sphere {normal_sum[1]!r} != m g {weight!r}")
        check(abs(normal_sum[0] - 3 * weight) <= 1e-9 * weight,
              f"{where}: normal forces on the lower sphere {normal_sum[0]!r} != 3 m g "
              "(the plane's 2 m g and the upper sphere's m g)")
        for i in (0, 1):
            net = p["force"][slot[i]] + particles_spec[i]["mass"] * gravity
            check(np.linalg.norm(net) <= 1e-9 * weight,
                  f"{where}: the resting sphere {i} feels a net force {net.tolist()}")
    check(tangential_seen, f"{label}: no contact with a tangential force (the spinning pair should make one)")
    return particles, contacts


def same_values(a, b, where):
    for (ta, pa), (tb, pb) in zip(a, b):
        check(ta == tb, f"{where}: times {ta!r} and {tb!r}")
        check(sorted(pa.keys()) == sorted(pb.keys()), f"{where} t={ta!r}: arrays differ: {sorted(pa)} vs {sorted(pb)}")
        for name in pa:
            if name in pb:
                check(np.array_equal(np.asarray(pa[name]), np.asarray(pb[name])),
                      f"{where} t={ta!r}: {name} differs between binary and ASCII")
    check(len(a) == len(b), f"{where}: {len(a)} and {len(b)} snapshots")


def main():
    dem, scene_path, work = sys.argv[1:4]
    with open(scene_path, "rb") as f:
        scene = tomllib.load(f)
    binary_out, ascii_out = os.path.join(work, "binary"), os.path.join(work, "ascii")
    run(dem, scene_path, binary_out, [])
    run(dem, scene_path, ascii_out, ["--set", 'output.vtk_format="ascii"'])
    with open(os.path.join(binary_out, "particles_1.vtp"), "rb") as f:
        text = f.read()
        check(b'format="appended"' in text
              and b'header_type="UInt64"' in text and b'<AppendedData encoding="raw">' in text,
              "the default snapshot is not appended raw binary with UInt64 headers")
    with open(os.path.join(ascii_out, "contacts_1.vtp"), "rb") as f:
        text = f.read()
        check(b'format="ascii"' in text and b"AppendedData" not in text, "vtk_format = ascii wrote binary")
    binary = check_run("binary", binary_out, scene)
    ascii_ = check_run("ascii", ascii_out, scene)
    same_values(binary[0], ascii_[0], "particles")
    same_values(binary[1], ascii_[1], "contacts")
    for message in failures[:40]:
        print("FAIL:", message)
    if failures:
        print(f"{len(failures)} failures")
        return 1
    print(f"ok: {len(binary[0])} snapshots of particles and contacts, binary and ASCII")
    return 0


if __name__ == "__main__":
    sys.exit(main())
