#!/usr/bin/env python3
"""Compares every table of the runs of record (`reports/<experiment>/record/tables/`) with the
tables of a fresh `motionlab reproduce --reports DIR` (`DIR/<experiment>/<run>/tables/`).

Every table of a record must be byte-identical to the fresh run's table of that name, except
the columns `TOLERANCES` names, which are compared as numbers within the tolerance stated there
(a column that is legitimately run-specific; none is at present: run-specific tables such as
`benchmark_runtime` are left out of the records by the experiments' `record_tables`). Every
experiment with a record must have a fresh run holding every recorded table; the fresh run's
other tables (parquet copies, tables the record leaves out) are counted, not compared. A difference fails with the file, the row and the column (the first differing cell
of each differing table). Standard library only.

Usage: bench/check_records.py FRESH_REPORTS_DIR [--records reports]
       bench/check_records.py --self-test FRESH_REPORTS_DIR   # broken copies must fail
"""
import argparse
import csv
import io
import os
import shutil
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# "experiment/table.csv" -> {column: absolute tolerance}: columns whose value may differ between
# two runs of the same code on the same data (timings, for instance). Each entry says why.
TOLERANCES = {}


def fresh_run(fresh, experiment):
    """The one run directory of `experiment` in the fresh reports (None if there is none)."""
    folder = os.path.join(fresh, experiment)
    if not os.path.isdir(folder):
        return None
    runs = sorted(d for d in os.listdir(folder) if os.path.isdir(os.path.join(folder, d, "tables")) and d != "record")
    if len(runs) != 1:
        raise SystemExit(f"{folder}: expected exactly one fresh run with tables/, found {runs}")
    return os.path.join(folder, runs[0])


def first_csv_difference(rel, recorded, fresh, tolerances):
    """Text of the first cell that differs beyond its column's tolerance (None: none)."""
    a = list(csv.reader(io.StringIO(recorded)))
    b = list(csv.reader(io.StringIO(fresh)))
    if not a or not b or a[0] != b[0]:
        return f"{rel}: header {a[0] if a else None} in the record, {b[0] if b else None} fresh"
    header = a[0]
    for row in range(1, max(len(a), len(b))):
        if row >= len(a) or row >= len(b):
            return f"{rel}: {len(a) - 1} data rows in the record, {len(b) - 1} fresh (first extra: row {row + 1})"
        ra, rb = a[row], b[row]
        if len(ra) != len(rb):
            return f"{rel}: line {row + 1}: {len(ra)} cells in the record, {len(rb)} fresh"
        for col, (x, y) in enumerate(zip(ra, rb)):
            if x == y:
                continue
            name = header[col] if col < len(header) else f"#{col + 1}"
            tol = tolerances.get(name)
            if tol is not None:
                try:
                    if abs(float(x) - float(y)) <= tol:
                        continue
                except ValueError:
                    pass
            return f"{rel}: line {row + 1}, column {name!r}: record {x!r}, fresh {y!r}"
    return None


def first_text_difference(rel, recorded, fresh):
    a, b = recorded.splitlines(), fresh.splitlines()
    for i in range(max(len(a), len(b))):
        x = a[i] if i < len(a) else None
        y = b[i] if i < len(b) else None
        if x != y:
            if x is not None and y is not None and x.startswith("|") and y.startswith("|"):
                ca, cb = x.split("|"), y.split("|")
                header = a[2].split("|") if len(a) > 2 else []
                for col, (u, v) in enumerate(zip(ca, cb)):
                    if u != v:
                        name = header[col].strip() if col < len(header) else f"#{col}"
                        return f"{rel}: line {i + 1}, column {name!r}: record {u.strip()!r}, fresh {v.strip()!r}"
            return f"{rel}: line {i + 1}: record {x!r}, fresh {y!r}"
    return f"{rel}: differs (line endings or trailing bytes)"


def compare(records, fresh):
    """(failures, tables compared)."""
    failures, compared = [], 0
    not_recorded = [0]
    experiments = sorted(e for e in os.listdir(records) if os.path.isdir(os.path.join(records, e, "record", "tables")))
    fresh_experiments = sorted(e for e in os.listdir(fresh) if os.path.isdir(os.path.join(fresh, e)))
    for e in sorted(set(fresh_experiments) - set(experiments)):
        failures.append(f"{e}: a fresh run but no reports/{e}/record/tables/")
    for experiment in experiments:
        rec = os.path.join(records, experiment, "record", "tables")
        run = fresh_run(fresh, experiment)
        if run is None:
            failures.append(f"{experiment}: a run of record but no fresh run in {fresh}")
            continue
        new = os.path.join(run, "tables")
        names_rec, names_new = set(os.listdir(rec)), set(os.listdir(new))
        for name in sorted(names_rec - names_new):
            failures.append(f"{experiment}/record/tables/{name}: not written by the fresh run")
        # The record keeps the tables its experiment's `record_tables` names (csv and md; no
        # parquet): the fresh run's other tables have nothing to be compared with.
        not_recorded[0] += len(names_new - names_rec)
        for name in sorted(names_rec & names_new):
            rel = f"reports/{experiment}/record/tables/{name}"
            with open(os.path.join(rec, name), "rb") as f:
                x = f.read()
            with open(os.path.join(new, name), "rb") as f:
                y = f.read()
            compared += 1
            if x == y:
                continue
            tolerances = TOLERANCES.get(f"{experiment}/{name}", {})
            xs, ys = x.decode("utf-8", "replace"), y.decode("utf-8", "replace")
            if name.endswith(".csv"):
                d = first_csv_difference(rel, xs, ys, tolerances)
                if d is None:
                    continue  # only within the stated tolerances
            else:
                d = first_text_difference(rel, xs, ys)
            failures.append(d)
    want = sum(len(os.listdir(os.path.join(records, e, "record", "tables"))) for e in experiments)
    if compared != want:
        failures.append(f"compared {compared} tables of the {want} recorded")
    if compared == 0:
        failures.append("no table compared")
    print(f"{not_recorded[0]} fresh tables not kept in any record (parquet copies, tables the experiments' record_tables leave out)")
    return failures, compared, len(experiments)


def self_test(records, fresh):
    """Copies of the fresh reports, each broken one way, must each fail."""
    def broken(kind):
        tmp = tempfile.mkdtemp(prefix="check-records-self-test.")
        copy = os.path.join(tmp, "fresh")
        shutil.copytree(fresh, copy)
        experiment = sorted(e for e in os.listdir(records) if os.path.isdir(os.path.join(records, e, "record", "tables")))[0]
        tables = os.path.join(fresh_run(copy, experiment), "tables")
        recorded = os.listdir(os.path.join(records, experiment, "record", "tables"))
        table = os.path.join(tables, sorted(n for n in recorded if n.endswith(".csv"))[0])
        if kind == "cell":  # one digit of the last cell of the second line changed
            lines = open(table).read().split("\n")
            last = lines[1].rstrip()
            i = max(j for j, c in enumerate(last) if c.isdigit())
            lines[1] = last[:i] + str((int(last[i]) + 1) % 10) + last[i + 1:]
            open(table, "w").write("\n".join(lines))
        elif kind == "missing table":
            os.remove(table)
        elif kind == "missing experiment":
            shutil.rmtree(os.path.join(copy, experiment))
        try:
            return compare(records, copy)[0]
        finally:
            shutil.rmtree(tmp)

    for kind in ("cell", "missing table", "missing experiment"):
        failures = broken(kind)
        if not failures:
            sys.exit(f"self-test: a fresh run with a {kind} passed")
        print(f"self-test ({kind}): fails as it should: {failures[0]}")
    print("self-test passed: every broken copy failed the comparison")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("fresh", help="the --reports folder of a fresh `motionlab reproduce`")
    ap.add_argument("--records", default=os.path.join(ROOT, "reports"))
    ap.add_argument("--self-test", action="store_true")
    args = ap.parse_args()
    if args.self_test:
        self_test(args.records, args.fresh)
        return
    failures, compared, experiments = compare(args.records, args.fresh)
    if failures:
        print(f"{len(failures)} table(s) differ from the runs of record:")
        for f in failures:
            print("  " + f)
        sys.exit(1)
    print(f"{compared} tables of {experiments} experiments identical to their runs of record")


if __name__ == "__main__":
    main()
