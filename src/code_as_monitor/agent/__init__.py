"""The closed loop: planner + painter + monitor around any policy, as a streaming :class:`Monitor`.

Import from the submodules (``agent.monitor``, ``agent.config``, ``agent.decision``, ``agent.drive``);
this package imports nothing heavy.
"""
