function [left_accel, right_accel] = getaccel(simrobot)
% GETACCEL  The angular acceleration of the left and right wheel (rad/s^2).
%   accel = getaccel(simrobot) returns the two-element vector [left_accel right_accel];
%   [left_accel, right_accel] = getaccel(simrobot) returns them separately.
  if nargout <= 1
    left_accel = simrobot.accel;
  else
    left_accel = simrobot.accel(1);
    right_accel = simrobot.accel(2);
  end
end
