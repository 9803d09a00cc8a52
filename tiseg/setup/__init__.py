"""Setting a run up: the scene schema, declared once, and what is derived from it.

* :mod:`.schema`: the metadata a section's dataclass fields carry (:func:`key`) and the generic
  reader and writer that walk them;
* :mod:`.table`: typed reads of one TOML table, every failure a one-line
  :class:`tiseg.errors.InputError` naming the dotted key;
* :mod:`.sections`: the scene's sections, each key declared once with its default, range or
  choices (read live from the registries), doc text and whether kernels are compiled for it;
* :mod:`.validators`: the cross-key rules, run after the generic read;
* :mod:`.reading` and :mod:`.writing`: a scene from TOML text, dicts and overrides, and back;
* :mod:`.reference`: the scenes reference page of the documentation.

:mod:`tiseg.setup.scene` keeps the public names (``load_scene``, ``Scene``, ``scene_to_dict``, ...).
"""
