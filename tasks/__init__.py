"""Package data, not code: the shipped scenarios (``*.toml``) and campaigns (``campaigns/``).
``pyproject.toml`` installs this folder as ``mjasc.tasks``; ``mjasc list`` shows them and
``mjasc run NAME`` runs one by name (:mod:`mjasc.core.resources`)."""
