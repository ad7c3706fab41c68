"""The rows of a measurement script: measured afresh and written to its CSV, or read back from the
CSV (--reuse) to redraw the tables and charts without measuring."""
import csv
import os


def measured_or_reused(path, measure, reuse):
    """measure() -> list of dicts, written to `path`; or, with reuse, the rows `path` holds."""
    if reuse:
        with open(path) as f:
            return list(csv.DictReader(f))
    rows = measure()
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    return rows
