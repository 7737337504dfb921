"""The README's table of the realism profiles, made from config/sim.yaml (values and their comments).

    rosrun mujoco_sim realism_table              # print the markdown table
    rosrun mujoco_sim realism_table --readme README.md   # write it between the realism markers

The comments of the `realism/table` keys say what each key means, its unit and why each profile has
its value; the table repeats them, so the README cannot drift from the configuration.
"""
import argparse
import os
import re
import sys

from ruamel.yaml import YAML

from .realism import PROFILES, validate_table

START, END = "<!-- realism:start -->", "<!-- realism:end -->"
DEFAULT_CONFIG = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "config", "sim.yaml")


def _comment_lines(token):
    """The text of a ruamel comment token (or list of them), line by line, without '#'."""
    if token is None:
        return []
    if isinstance(token, list):
        return [line for item in token for line in _comment_lines(item)]
    return [line.strip().lstrip("#").strip() for line in token.value.splitlines() if line.strip()]


def rows(path=DEFAULT_CONFIG):
    """(key, values by profile, description, section heading or None) in file order."""
    with open(path) as stream:
        data = YAML().load(stream)
    table = data["realism"]["table"]
    validated = validate_table({k: list(v) for k, v in table.items()}, list(data["realism"]["profiles"]), path)
    out = []
    keys = list(table)
    heading = None
    for index, key in enumerate(keys):
        tokens = table.ca.items.get(key) or [None, None, None, None]
        lines = _comment_lines(tokens[2]) if len(tokens) > 2 else []
        # ruamel gives a key's trailing comment, then its continuation lines and the next block's heading
        # (a line starting with ---) as one token.
        description, next_heading = [], None
        for line in lines:
            if line.startswith("---"):
                next_heading = line.strip("- ").strip()
            else:
                description.append(line)
        if index == 0:  # the first block's heading is the comment after 'table:' itself
            parent = data["realism"].ca.items.get("table") or []
            start = [line for token in parent if token is not None for line in _comment_lines(token)]
            heading = next((line.strip("- ").strip() for line in start if line.startswith("---")), None)
        out.append((key, {name: validated[name][key] for name in PROFILES}, " ".join(description), heading))
        heading = next_heading
    return out


def _format(value):
    if isinstance(value, bool):
        return "yes" if value else "no"
    return "%g" % value


def markdown(path=DEFAULT_CONFIG):
    lines = ["| key | ideal | realistic | harsh | what it is, and why these values |", "|---|---|---|---|---|"]
    for key, values, description, heading in rows(path):
        if heading:
            lines.append("| **%s** | | | | |" % heading)
        lines.append("| `%s` | %s | %s | %s | %s |" % (key, *(_format(values[p]) for p in PROFILES),
                                                        description.replace("|", "\\|")))
    return "\n".join(lines) + "\n"


def update_readme(readme, table):
    text = open(readme).read()
    pattern = re.compile(re.escape(START) + ".*?" + re.escape(END), re.S)
    if not pattern.search(text):
        raise SystemExit("%s has no %s ... %s block to write the table into" % (readme, START, END))
    new = pattern.sub(lambda _: START + "\n" + table + END, text)
    with open(readme, "w") as stream:
        stream.write(new)


def main(argv=None):
    parser = argparse.ArgumentParser(description="Markdown table of the realism profiles from config/sim.yaml.")
    parser.add_argument("--config", default=DEFAULT_CONFIG, help="simulator parameter file")
    parser.add_argument("--readme", help="write the table into this file's realism block instead of printing it")
    args = parser.parse_args(argv)
    table = markdown(args.config)
    if args.readme:
        update_readme(args.readme, table)
    else:
        sys.stdout.write(table)
    return 0
