"""The arm's window: the 3D arm page, its scene, display meshes and ROS client."""
