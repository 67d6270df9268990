"""MATLAB/Octave programs against our worlds: the Create toolbox bridge (:mod:`.bridge`) and the
folder of m-files installed with the package (:mod:`.paths`, ``robot_sims matlab_path``)."""
