"""The base every node needs: clock and stepping, parameters, QoS, TF, messages, paths, files, bags. Imports no simulator."""
