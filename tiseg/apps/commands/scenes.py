"""`tiseg scenes`: the built-in scenes, and one of them as a TOML file to start from.

``tiseg scenes`` lists each built-in scene with its one-line description;
``tiseg scenes show NAME > my.toml`` prints the scene's file as shipped, comments included (the
paper's equations and figures its values come from), so that ``tiseg run my.toml`` runs it and
an edited copy runs the edited experiment. ``--resolved`` prints every key instead, defaults
filled in (what a run writes as its ``scene.toml``). ``tiseg scenes schema`` prints the scene
schema as a JSON Schema for editors (`tiseg.setup.json_schema`).
"""

from __future__ import annotations

import sys
from ...data import SCENE_DIR, builtin_file
from ...errors import InputError


# `tiseg scenes --help` ends with these (`tiseg.apps.examples`); a test parses each.
EXAMPLES = [
    ("tiseg scenes", "list the built-in scenes"),
    ("tiseg scenes show fingers > my.toml", "a scene file to edit, then `tiseg run my.toml`"),
    ("tiseg scenes show fingers --resolved", "every key with its value"),
    ("tiseg scenes schema > scene.schema.json", "the JSON Schema of a scene, for editors"),
]


def register(sub) -> None:
    p = sub.add_parser(
        "scenes",
        help="list the built-in scenes; print one as TOML to start from",
        description="List the built-in scenes with their descriptions, or print one as a TOML "
        "file to start from: `tiseg scenes show fingers > my.toml`, edit it, then "
        "`tiseg run my.toml`.",
    )
    p.set_defaults(func=list_scenes)
    actions = p.add_subparsers(dest="action", metavar="ACTION")
    show = actions.add_parser(
        "show",
        help="print a built-in scene as TOML (on stdout)",
        description="Print the built-in scene NAME as TOML on stdout, with the comments that "
        "say where its values come from; redirect it into a file to start a scene of your own.",
    )
    show.add_argument("name", metavar="NAME", help="a built-in scene (see `tiseg scenes`)")
    show.add_argument(
        "--resolved",
        action="store_true",
        help="every key, defaults filled in (as a run's scene.toml), instead of the file as "
        "shipped",
    )
    show.set_defaults(func=show_scene)
    schema = actions.add_parser(
        "schema",
        help="print the JSON Schema of a scene file (on stdout), for editors",
        description="Print the scene schema as a JSON Schema (draft 2020-12) on stdout: every "
        "section and key with its doc, type, range, choices and default. TOML editors that "
        "read JSON Schemas (Taplo, VS Code's Even Better TOML) then complete and check a "
        "scene file as you type; the rules that tie keys together are checked by `tiseg run`.",
    )
    schema.set_defaults(func=print_schema)


def list_scenes(args) -> int:
    from ...setup.scene import list_builtin_scenes, load_scene

    names = list_builtin_scenes()
    scenes = [load_scene(n) for n in names]
    width = max((len(n) for n in names), default=0)
    for name, scene in zip(names, scenes):
        print(f"{name:<{width}}  {scene.description}")
    if sys.stdout.isatty():  # a hint for a person, not for a pipe
        print(
            "\n`tiseg scenes show NAME > my.toml` prints one to start from; `tiseg run NAME` runs it"
        )
    return 0


def show_scene(args) -> int:
    from ...setup.scene import list_builtin_scenes, load_scene

    name = args.name
    if "/" in name or "\\" in name or name.endswith(".toml"):
        raise InputError(
            f"{name!r} is not a built-in scene name; built-in scenes: "
            f"{', '.join(list_builtin_scenes())}"
        )
    path = builtin_file(name, SCENE_DIR, "scene")  # an unknown name: the closest one, one line
    if args.resolved:
        sys.stdout.write(load_scene(name).to_toml())
    else:
        sys.stdout.write(path.read_text(encoding="utf-8"))
    return 0


def print_schema(args) -> int:
    import json

    from ...setup.json_schema import scene_schema

    sys.stdout.write(json.dumps(scene_schema(), indent=2) + "\n")
    return 0
