"""The README's Python example runs as written (matplotlib replaced by a stand-in that
records what it was asked to show), from the repository's root as the README assumes."""

from __future__ import annotations

import os
import sys
import types

import numpy as np

from conftest import REPO


def test_readme_example_runs() -> None:
    text = (REPO / "README.md").read_text()
    section = text.index("## Python")
    start = text.index("```python\n", section) + len("```python\n")
    code = text[start : text.index("```", start)]
    shown = []

    class Axes:
        def imshow(self, image: np.ndarray) -> None:
            shown.append(image)

        def set_title(self, title: str) -> None:
            pass

    pyplot = types.ModuleType("matplotlib.pyplot")
    pyplot.subplots = lambda *a, **k: (None, [Axes(), Axes()])  # type: ignore[attr-defined]
    pyplot.show = lambda: None  # type: ignore[attr-defined]
    matplotlib = types.ModuleType("matplotlib")
    matplotlib.pyplot = pyplot  # type: ignore[attr-defined]
    saved = {k: sys.modules.get(k) for k in ("matplotlib", "matplotlib.pyplot")}
    sys.modules.update({"matplotlib": matplotlib, "matplotlib.pyplot": pyplot})
    cwd = os.getcwd()
    try:
        os.chdir(REPO)
        exec(compile(code, "README.md", "exec"), {})
    finally:
        os.chdir(cwd)
        for k, v in saved.items():
            if v is None:
                sys.modules.pop(k, None)
            else:
                sys.modules[k] = v
    assert len(shown) == 2
    assert shown[0].dtype == np.uint8 and shown[0].shape == (1156, 1734, 3)
    assert shown[1].shape == (1156, 1734, 3) and float(shown[1].max()) <= 1.0
