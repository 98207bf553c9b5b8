"""The scenarios: landmarks (scenario A), the robot, the terrain flights, the robot on a map.

Each one a subpackage with its scenario, simulation, model and Kalman-family references;
they import the core and themselves, never one another."""
