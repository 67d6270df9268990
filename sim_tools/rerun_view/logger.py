"""Draw ROS messages as Rerun archetypes: one mapping shared by ``bag_to_rerun`` and the live view.

Rerun's own MCAP import draws no LaserScan, Odometry or Marker, so :class:`RerunLogger` turns each
message of the worlds' topics into archetypes on the ``sim_time`` timeline. Mobile robots live on a
flat map and are drawn in 2-D (a true top-down view, +y up); arms are drawn in 3-D:

======================================  =========================================================
entity                                  what
======================================  =========================================================
``top``                                 origin of the top-down views
``top/map``                             the ``map`` frame, mirrored in y so +y points up on screen
``top/map/grid``                        a line every metre, labelled at the edges
``top/map/occupancy``                   an OccupancyGrid as a grey image (walls dark)
``top/map/map_markers/<ns>/<id>``       the Create's map (walls, painted lines, beacons, virtual
                                        walls), static
``top/map/markers/<topic>/<ns>/<id>``   other MarkerArrays in 2-D (``/robots`` outlines…)
``top/map/robots/<robot>``              ground-truth pose (``overhead_pose``, ``pose``; ``odom``
                                        if there is none); ``body``: outline or dot, heading arrow
``top/map/robots/<robot>/follow``       a frame at the robot, north up: origin of its own view;
                                        ``label``: name, obstacle number, power and crash state
``top/map/robots/<robot>/<sensor>``     sensor frames at their mount (TF, else the known mounts):
                                        scan points, sonar beam cone and hit, lit detectors
``top/map/tracks/<robot>/{truth,odom}``  tracks in the robot's colour (strips of segments)
``top/map/marks/<robot>/{contacts,crashes}``  crosses where a bumper was pressed or the robot
                                        crashed, unlabelled (Events has the times), kept
``world``                               3-D frame of arms: meshes, axes, target pose,
                                        ``paths/<topic>`` end-effector path
``plots/<tab>/<robot>/<series>``        scalars, one time-series tab per quantity
``events/<robot>``                      text log: contacts (INFO), crashes (WARN), power switched
                                        (INFO), detectors (DEBUG), each on and off
``legend``                              a text panel saying what each colour and mark means
======================================  =========================================================

Robots are named by their namespace (``robot`` for the root namespace); sensor frames
``<ns>/<sensor>`` belong to robot ``<ns>``. A sensor's mount comes from the bag's ``/tf_static``
(``<ns>/base_link`` → sensor) when it has one, else from the robot's simulator's known mounts,
else the robot's centre.

The drawing is the kit's (:mod:`sim_tools.rerun_kit`: one module per message family — poses,
sensors, markers, inputs — over robots, plots and the canvas, and the blueprint builder); what is
one simulator's comes from its adapter.

The ``rerun`` part of a simulator's adapter
-------------------------------------------
A registered simulator (:mod:`sim_tools.adapters`) whose adapter has a ``rerun`` module is drawn
by it: the module holds ``DRAWING``, an instance of a subclass of
:class:`sim_tools.rerun_kit.contract.SimulatorDrawing`. It imports the kit (never this module)
and declares, each optional (topic names are last segments):

- **its robots**: ``look`` (a :class:`~sim_tools.rerun_kit.contract.RobotLook`: body, heading
  arrow, label offset, the width of the view following the robot, known sensor mounts) for the
  namespaces ``owns_robot(namespace, topics)`` accepts; the others get the default look (a dot);
  ``truth_pose_topics``, its robots' ground-truth PoseStamped topics;
- **topics it claims**: ``handlers``, ``(topic, pkg/msg/Type)`` (or ``(None, type)``: every topic
  of that type no drawing claims by name) → ``draw(drawer, topic, msg)``, called instead of the
  kit's family for that type;
  it draws with the public methods of :class:`~sim_tools.rerun_kit.drawer.Drawer` (``robot``,
  ``frame_entity``, ``scalar``, ``binary``, ``event``, ``mark``, ``joints``…). The types it
  claims are drawn types (``supported_types``). ``quiet_topics`` are skipped without a warning;
- **its map and scene**: ``map_marker_topics`` (static, ``top/map/<topic>``, the map's extent),
  ``wall_namespaces`` (faded markers are cut at the walls), ``faded_markers`` (namespace →
  opacity), ``static_marker_topics`` (a latched scene), ``path_topics`` (poses drawn with their
  path in 3-D), ``grid_shade(topics)`` (grey of an OccupancyGrid's occupied cells);
- **colours from the world**: ``outline_topics`` and ``outlines(markers)`` (robots take the colour
  and number of the outline within ``outline_match_m`` of them, and wait for it);
  ``scan_colors(msg, hit)`` (a LaserScan's hit colours from its intensities);
  ``detector_style(name)`` (a detector's event level, and whether it is a contact: red, marked);
- **the blueprint**: ``plot_tabs`` (its quantities' tabs, ordered by rank among the kit's),
  ``legend_notes(leaves)`` and ``legend_lines(topics)`` (ranked lines of the legend),
  ``legend_3d`` (the legend of a 3-D world).

The first drawing (in registry order) that claims a topic (by name before by type), owns a robot
or answers a hook wins.
"""

from __future__ import annotations

from collections.abc import Sequence

import rerun as rr

from sim_tools.adapters import simulators
from sim_tools.rerun_kit import drawer
from sim_tools.rerun_kit.contract import SimulatorDrawing

TOOL = "rerun"
"""The adapters' part read here."""


def registered_drawings() -> list[SimulatorDrawing]:
    """The ``DRAWING`` of every registered simulator with a ``rerun`` part, in registry order."""
    return [sim.part(TOOL).DRAWING for sim in simulators().values() if sim.has_part(TOOL)]


def supported_types() -> frozenset[str]:
    """Message types the views draw (``Clock`` is accepted and only drives time)."""
    return drawer.supported_types(registered_drawings())


def quiet_topics() -> frozenset[str]:
    """Last topic segments the simulators say have nothing to draw."""
    return frozenset(t for d in registered_drawings() for t in d.quiet_topics)


class RerunLogger(drawer.Drawer):
    """The kit's :class:`~sim_tools.rerun_kit.drawer.Drawer` with the registered simulators'
    drawings (or ``drawings``, if given)."""

    def __init__(
        self,
        recording: rr.RecordingStream,
        topics: dict[str, str] | None = None,
        *,
        batch_scalars: bool = False,
        drawings: Sequence[SimulatorDrawing] | None = None,
    ) -> None:
        chosen = registered_drawings() if drawings is None else drawings
        super().__init__(recording, topics, drawings=chosen, batch_scalars=batch_scalars)
