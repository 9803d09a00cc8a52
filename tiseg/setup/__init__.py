"""Setting a run up: the scene schema, declared once, and what is derived from it.

* `schema`: the metadata a section's dataclass fields carry (`key`) and the generic
  reader and writer that walk them;
* `table`: typed reads of one TOML table, every failure a one-line
  `tiseg.errors.InputError` naming the dotted key;
* `sections`: the scene's sections, each key declared once with its default, range or
  choices (read live from the registries), doc text and whether kernels are compiled for it;
* `validators`: the cross-key rules, run after the generic read;
* `reading` and `writing`: a scene from TOML text, dicts and overrides, and back;
* `reference`: the scenes reference page of the documentation;
* `terrain`, `rasters`, `terrain_section`, `bed`: the bed from shapes and rasters, the
  ``[terrain]`` keys, and the section read, written and put on the cells.

`tiseg.setup.scene` keeps the public names (``load_scene``, ``Scene``, ``scene_to_dict``, ...).
"""
