function [left_vel, right_vel] = getvel(simrobot)
% GETVEL  The angular velocities of the left and right wheel (rad/s).
%   vel = getvel(simrobot) returns the two-element vector [left_vel right_vel];
%   [left_vel, right_vel] = getvel(simrobot) returns them separately.
  if nargout <= 1
    left_vel = simrobot.velocity;
  else
    left_vel = simrobot.velocity(1);
    right_vel = simrobot.velocity(2);
  end
end
