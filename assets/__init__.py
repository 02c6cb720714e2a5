"""Package data, not code: the vessel models (``vessels/<name>/``, MJCF + hydrodynamics.toml +
README) and the water scene. ``pyproject.toml`` installs this folder as ``mjasc.assets``; mjasc
finds it with :func:`mjasc.core.resources.assets_dir`."""
