function [velocity, accel, power, crashed] = simrobot_commands(r)
% SIMROBOT_COMMANDS  (system) What the algorithm left in the robot, for the world to apply.
  velocity = r.velocity;
  accel = r.accel;
  power = r.power;
  crashed = r.crashed;
end
