"""A checkout folder named ``mjchar``, imported from the folder above it, is the package.

``git clone`` names the checkout ``mjchar``. Python started in the folder above it finds that
folder first on ``sys.path`` and, with no ``__init__.py`` there, would import it as an empty
namespace package that hides the installed one (``import mjchar`` gives no ``__version__``,
``gymnasium.make("mjchar/...")`` no environments). This file makes that import load the real
package, ``mjchar/__init__.py``, with the checkout's folders found as pyproject's package-dir
maps them (``bvh/`` is ``mjchar.bvh``, ``controllers/`` ``mjchar.controllers``...).

It is not part of the package: the wheel and the editable install never import it.
"""

import importlib.util as _util
import os as _os
import sys as _sys

if __name__ == "mjchar":
    _root = _os.path.dirname(_os.path.abspath(__file__))
    _spec = _util.spec_from_file_location(
        "mjchar", _os.path.join(_root, "mjchar", "__init__.py"),
        submodule_search_locations=[_os.path.join(_root, "mjchar"), _root])
    _package = _util.module_from_spec(_spec)
    _sys.modules["mjchar"] = _package  # what `import mjchar` returns from here on
    _spec.loader.exec_module(_package)
