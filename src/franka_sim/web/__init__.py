"""The web view (`serve --web PORT`, `franka-sim view`): the world in 3D and each arm's live
plots in a browser, served by viser (the optional extra `franka-sim[web]`).

Nothing here is imported unless the view is asked for: `web_missing()` only asks whether viser
is installed.
"""

from __future__ import annotations

import importlib.util

INSTALL = "pip install 'franka-sim[web]'"


def web_missing() -> str | None:
    """One line saying what to install for the web view, or None when it can be served."""
    if importlib.util.find_spec("viser") is None:
        return f"the web view needs viser: {INSTALL}"
    return None
