"""Code-as-Monitor: constraint-aware visual programming for reactive and proactive failure detection.

The package is layered (see ``docs/architecture.md``): ``core`` -> ``geometry`` -> ``perception``/``vlm``
-> ``painter``/``monitor`` -> ``planning`` -> ``agent`` -> ``sim``/``baselines`` -> ``bench``/``viz``/``cli``.
Importing the package imports no backend.
"""

__version__ = "0.1.0"
