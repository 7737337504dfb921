"""results.csv of a sweep, written row by row as runs finish (append, flush), so that an interrupted sweep
keeps every finished run and ``--resume`` runs only the rest. A run is identified by (name, run index);
a row for a run already in the file is never written again."""
import csv
import os

CSV_FIELDS = ("name", "run", "file", "vehicle", "path", "speed_mps", "wind_speed", "realism", "outcome", "expected", "passed",
              "touchdown_error_m", "time_to_land_s", "decisions", "emergency_position", "sim_time_s", "wall_time_s",
              "real_time_factor", "node", "error")
_FLOATS = ("speed_mps", "wind_speed", "touchdown_error_m", "time_to_land_s", "sim_time_s", "wall_time_s",
           "real_time_factor")


class ResultsFileError(ValueError):
    pass


def key(row):
    return row["name"], int(row["run"])


def parse(row):
    """A row read back from the CSV with the types benchmark.summarize works on."""
    out = dict(row)
    for field in _FLOATS:
        out[field] = float(row[field]) if row.get(field) not in (None, "") else None
    out["run"] = int(row["run"])
    out["passed"] = row["passed"] == "True"
    out["decisions"] = int(row["decisions"]) if row.get("decisions") not in (None, "") else 0
    for field in ("vehicle", "path", "error", "node"):
        out[field] = row.get(field) or None
    return out


def _complete(row):
    """False for the last line of a sweep killed in the middle of writing it."""
    return None not in row.values() and row.get("passed") in ("True", "False") and row.get("run", "").isdigit()


class ResultsFile:
    """``path`` opened for appending rows. With ``resume``, the rows already there are kept (``rows``) and
    a torn last line is dropped; without, the file starts anew."""

    def __init__(self, path, resume):
        self.path, self.rows = path, []
        if resume and os.path.isfile(path):
            with open(path, newline="") as stream:
                reader = csv.DictReader(stream)
                if tuple(reader.fieldnames or ()) != CSV_FIELDS:
                    raise ResultsFileError("%s has the columns %s, not those of this benchmark; resume into the "
                                           "directory of a sweep of this version, or start a new --out"
                                           % (path, ",".join(reader.fieldnames or [])))
                seen = set()
                for row in reader:
                    if _complete(row) and key(row) not in seen:
                        seen.add(key(row))
                        self.rows.append(parse(row))
        # The kept rows go to a new file that replaces the old one whole: a sweep killed now loses nothing.
        with open(path + ".tmp", "w", newline="") as stream:
            writer = csv.DictWriter(stream, fieldnames=CSV_FIELDS, extrasaction="ignore")
            writer.writeheader()
            writer.writerows(self.rows)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(path + ".tmp", path)
        self._stream = open(path, "a", newline="")
        self._writer = csv.DictWriter(self._stream, fieldnames=CSV_FIELDS, extrasaction="ignore")
        self.done = {key(row) for row in self.rows}

    def append(self, row):
        """Writes ``row`` unless its run is already in the file; returns whether it was written."""
        if key(row) in self.done:
            return False
        self._writer.writerow(row)
        self._stream.flush()
        os.fsync(self._stream.fileno())
        self.done.add(key(row))
        self.rows.append(row)
        return True

    def close(self):
        self._stream.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False
