"""The studio's shell: the app and what every page shares (UI kit, ROS node, child processes,
workspace, SVG view). It imports no page: the entry point (:mod:`studio.main`) hands it the pages."""
