"""What the host, the twin and the tools share that is not the wire protocol: the YAML field
reader, command-line argument types, ROS 2 detection, spin-polling, the benchmark record."""
