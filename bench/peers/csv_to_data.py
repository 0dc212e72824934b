#!/usr/bin/env python3
"""Writes a LIGGGHTS data file (atom_style granular; LAMMPS reads it as atom_style sphere) from a particle CSV of scenes/data/
(id, x, y, z, vx, vy, vz, wx, wy, wz, radius, density), so LIGGGHTS starts from exactly the
particles our dense_bed scene loads. Our ids start at 0, LAMMPS atom ids at 1: an atom's id is
ours plus one. Usage: csv_to_data.py IN.csv OUT.data"""
import csv
import sys


def main(source, target):
    with open(source, newline="") as f:
        rows = list(csv.DictReader(f))
    with open(target, "w") as out:
        out.write(f"LIGGGHTS data file from {source}\n\n{len(rows)} atoms\n1 atom types\n\n")
        out.write("0 0.3 xlo xhi\n0 0.3 ylo yhi\n0 0.4 zlo zhi\n\nAtoms\n\n")
        for r in rows:  # id type diameter density x y z
            out.write(f"{int(r['id']) + 1} 1 {2 * float(r['radius']):.17g} {r['density']} {r['x']} {r['y']} {r['z']}\n")
        out.write("\nVelocities\n\n")
        for r in rows:  # id vx vy vz wx wy wz
            out.write(f"{int(r['id']) + 1} {r['vx']} {r['vy']} {r['vz']} {r['wx']} {r['wy']} {r['wz']}\n")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
