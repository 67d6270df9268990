"""The Rerun drawing kit: ROS messages drawn as Rerun archetypes, with no simulator in it.

``sim_tools.rerun_view`` (``bag_to_rerun``, the live view) draws with :class:`.drawer.Drawer`,
giving it the :class:`.contract.SimulatorDrawing` of every registered simulator; the simulators'
adapters (``sim_tools.adapters.<name>.rerun``) import this kit and it imports none of them.

Modules, each on the ones before it: ``style`` (entity roots, colours), ``ros`` (message fields
as Rerun values), ``shapes``, ``tf``, ``contract`` (what a simulator's drawing declares),
``state`` (tracks, robots, series), ``canvas`` (the recording, time, topics, map extent and
grid), ``plots`` (time series, events), ``robots`` (bodies, labels, frames, mounts, marks,
detectors), the message families ``poses``, ``sensors``, ``markers``, ``inputs``, then
``legend`` and ``blueprint`` (the layout), and ``drawer`` (one message → its family).
"""
