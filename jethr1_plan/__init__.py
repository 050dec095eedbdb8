"""jethr1-plan: thrust-assisted quasistatic stepping over ditches for the Jet-HR1 biped (Paper A) and
walking with pelvic rotation (Paper B).

The package is layered, lowest first (``tools/check_imports.py`` holds the layers; docs/architecture.md
explains them): the shared words (:mod:`.errors`, :mod:`.reasons`, :mod:`.geometry`), :mod:`.io`,
:mod:`.robot`, :mod:`.records`, :mod:`.physics`, :mod:`.kinematics`, :mod:`.optimisers`, :mod:`.scenario` and
:mod:`.swing_path`, :mod:`.control`, :mod:`.planning` / :mod:`.walking` / :mod:`.balance_space`,
:mod:`.files`, :mod:`.folders`, :mod:`.sim`, :mod:`.verify`, :mod:`.pipeline`, :mod:`.studies`, :mod:`.viewer`,
:mod:`.cli`.
"""

__version__ = "0.1.0"
__all__ = ["__version__"]
