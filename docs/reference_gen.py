"""The generated reference pages of the documentation site, rendered from the code itself.

- :func:`command_reference` walks the Typer app of ``tactile`` and renders every command's
  ``--help`` exactly as the terminal shows it (so the page cannot drift from the CLI);
- :func:`api_reference` writes one mkdocstrings block per public verb of ``tactile_cli``
  (the names ``tactile_cli/__init__.py`` imports or loads lazily from ``_VERBS``), so a verb
  added to the table appears in the reference with its docstring;
- :func:`schema_reference` renders the HDF5 schema from the JSON spec shipped in the package.

``docs/hooks.py`` calls them while MkDocs builds; ``tests/docs`` checks them without MkDocs.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

#: Width of the rendered ``--help`` (columns): wide enough that rich wraps no option name.
HELP_COLUMNS = 100


@dataclass(frozen=True)
class CommandEntry:
    """One command of the app: its words after ``tactile`` and its one-line summary."""

    path: tuple[str, ...]
    summary: str

    @property
    def name(self) -> str:
        return " ".join(("tactile", *self.path))

    @property
    def anchor(self) -> str:
        return "-".join(("tactile", *self.path))


def _click_root():  # the click group behind the Typer app
    import typer

    from tactile_cli.cli import app

    return typer.main.get_command(app)


def iter_commands() -> Iterator[CommandEntry]:
    """Every leaf command of ``tactile`` (groups such as ``simulate`` are walked into), in
    the order ``tactile --help`` lists them."""
    root = _click_root()

    def walk(group, prefix: tuple[str, ...]) -> Iterator[CommandEntry]:
        # typer ships its own copy of click: groups are told by what they do
        ctx = group.context_class(group)
        for name in group.list_commands(ctx):
            command = group.get_command(ctx, name)
            if command is None or command.hidden:
                continue
            if hasattr(command, "list_commands"):
                yield from walk(command, (*prefix, name))
            else:
                text = (command.short_help or command.help or "").strip()
                summary = " ".join(text.split("\n\n")[0].split())
                yield CommandEntry((*prefix, name), summary)

    yield from walk(root, ())


def render_help(path: tuple[str, ...]) -> str:
    """``tactile PATH --help`` as plain text, :data:`HELP_COLUMNS` wide, no colour."""
    from typer.testing import CliRunner

    from tactile_cli.cli import app

    env = {"COLUMNS": str(HELP_COLUMNS), "NO_COLOR": "1", "TERM": "dumb"}
    result = CliRunner().invoke(app, [*path, "--help"], env=env, prog_name="tactile")
    if result.exit_code != 0:
        raise RuntimeError(f"tactile {' '.join(path)} --help exited {result.exit_code}: "
                           f"{result.output}")
    return "\n".join(line.rstrip() for line in result.output.strip("\n").splitlines())


def command_reference() -> str:
    """The body of the command reference: an index table, then every command's help."""
    entries = list(iter_commands())
    lines = [f"`tactile` has {len(entries)} commands. This page is rendered from the app "
             "itself while the site builds (`docs/reference_gen.py`): each section is the "
             "command's `--help`, word for word.", "",
             "| command | what it does |", "| --- | --- |"]
    lines += [f"| [`{e.name}`](#{e.anchor}) | {e.summary.replace('|', '/')} |"
              for e in entries]
    lines += ["", "## `tactile`", "", "```text", render_help(()), "```", ""]
    for e in entries:
        lines += [f"## `{e.name}` {{#{e.anchor}}}", "", "```text", render_help(e.path),
                  "```", ""]
    return "\n".join(lines)


def public_verbs() -> dict[str, str]:
    """Every public name of ``tactile_cli`` that a notebook uses, by the dotted path of the
    object that defines it: the eager imports of the package and the lazy ``_VERBS`` table."""
    import tactile_cli

    names: dict[str, str] = {}
    eager = ["ingest", "describe_recording", "validate_file", "summarize", "open_file",
             "TactileFile", "Trial", "read_events", "read_events_window", "read_signal",
             "StoreWriter", "InputError", "SchemaError", "TactileError"]
    for name in eager:
        obj = getattr(tactile_cli, name)
        names[name] = f"{obj.__module__}.{obj.__qualname__}"
    for name, module in tactile_cli._VERBS.items():
        names[name] = f"tactile_cli.{module}.{name}"
    return names


#: Sections of the API page: a heading and the public names under it, in workflow order.
API_SECTIONS: list[tuple[str, list[str]]] = [
    ("Data in and out", ["ingest", "describe_recording", "validate_file", "summarize",
                         "open_file", "TactileFile", "Trial", "read_events",
                         "read_events_window", "read_signal", "StoreWriter"]),
    ("Errors", ["TactileError", "InputError", "SchemaError"]),
    ("Event camera (paper 000)", ["simulate_marker_events", "accumulate_file",
                                  "fit_fos_file", "fit_files", "synthesize",
                                  "write_centroid_file", "write_frames", "estimate_slip_rates",
                                  "slip_rate_report", "grade_trials", "grade_files"]),
    ("Accelerometer fingertip (paper 001)", ["simulate_vibro_slip", "prepare_file",
                                             "detection_delay"]),
    ("Camera-based DIGIT/GelSight (paper 002)", ["simulate_digit_press",
                                                 "simulate_digit_avoidance",
                                                 "write_normal_labels", "heightmap_file",
                                                 "slip_signal_file", "monitor_input"]),
    ("Active vibration (paper 003)", ["simulate_vibrotouch", "model_spectra", "model_file",
                                      "detect_contacts", "detect_contact_file", "find_band",
                                      "follow_input"]),
    ("Taxel arrays (paper 004)", ["simulate_taxel_slip", "slip_interface",
                                  "slip_interface_file", "write_taxel_features",
                                  "write_stream_features"]),
    ("Learning and evaluation", ["train_run", "evaluate_run", "compare", "compare_runs",
                                 "perturb_evaluate", "perturb_runs", "export_run",
                                 "run_sweep", "seed_spread", "evaluate_spread",
                                 "build_report"]),
    ("Figures", ["quicklook", "write_quicklook"]),
]


def api_reference() -> str:
    """mkdocstrings blocks for every public verb, grouped by :data:`API_SECTIONS`."""
    verbs = public_verbs()
    listed = [name for _, names in API_SECTIONS for name in names]
    missing = sorted(set(verbs) - set(listed))
    unknown = sorted(set(listed) - set(verbs))
    if missing or unknown:
        raise RuntimeError(f"API_SECTIONS out of date: not listed {missing}, unknown {unknown}")
    lines: list[str] = []
    for title, names in API_SECTIONS:
        lines += [f"## {title}", ""]
        for name in names:
            lines += [f"::: {verbs[name]}", "    options:", "      heading_level: 3", ""]
    return "\n".join(lines)


def _cell(text: object) -> str:
    return str(text).replace("|", "/").replace("\n", " ")


def schema_reference() -> str:
    """The HDF5 layout from ``tactile_cli/data_schemas/*.json``, the spec every file copies
    into ``/schema/spec_json``: its enums, then one table row per node and one table of
    attributes per node that has any."""
    import tactile_cli

    folder = Path(tactile_cli.__file__).parent / "data_schemas"
    lines: list[str] = []
    for spec_path in sorted(folder.glob("*.json")):
        spec = json.loads(spec_path.read_text(encoding="utf-8"))
        lines += [f"## `{spec_path.name}`: {spec['schema_name']} "
                  f"{spec['schema_version']}", "", spec["description"], "",
                  "### Enumerations", "", "| name | values |", "| --- | --- |"]
        lines += [f"| `{name}` | {', '.join(f'`{v}`' for v in values)} |"
                  for name, values in spec["enums"].items()]
        lines += ["", "### Nodes", "", "| path | type | dtype, ndim | required | what |",
                  "| --- | --- | --- | --- | --- |"]
        for node in spec["nodes"]:
            shape = ", ".join(str(node[k]) for k in ("dtype", "ndim") if k in node)
            lines.append(f"| `{node['path']}` | {node['type']} | {_cell(shape)} | "
                         f"{'yes' if node.get('required') else 'no'} | "
                         f"{_cell(node.get('doc', ''))} |")
        lines += ["", "### Attributes", ""]
        for node in spec["nodes"]:
            attrs = node.get("attributes") or {}
            if not attrs:
                continue
            lines += [f"`{node['path']}`", "", "| attribute | type | required | what |",
                      "| --- | --- | --- | --- |"]
            for name, attr in attrs.items():
                what = attr.get("doc", "")
                for key in ("const", "enum", "pattern", "unit"):
                    if key in attr:
                        what = f"{what} ({key} `{_cell(attr[key])}`)".strip()
                lines.append(f"| `{name}` | {attr.get('type', '')} | "
                             f"{'yes' if attr.get('required') else 'no'} | {_cell(what)} |")
            lines.append("")
        if spec.get("checks"):
            lines += ["### Checks beyond the layout", ""]
            for check in spec["checks"]:
                paths = ", ".join(f"`{p}`" for p in check.get("paths", []))
                doc = f": {check['doc']}" if check.get("doc") else ""
                lines.append(f"- `{check.get('check', '?')}` {_cell(paths)}{_cell(doc)}")
            lines.append("")
    return "\n".join(lines)
