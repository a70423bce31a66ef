"""The project's one writer: :mod:`fuzzynav.safe_files` under its former name.

It moved to the package's root so that the controller's savers use it too (the app may
import the controller, never the reverse). This name is the same module object, so
that patching ``fuzzynav.app.safe_files.commit`` patches the one every writer calls.
"""

import sys

from fuzzynav import safe_files as _safe_files

sys.modules[__name__] = _safe_files
