function new = setaccel(simrobot, accel)
% SETACCEL  Set the angular acceleration of the left and right wheel.
%   new = setaccel(simrobot, [left_accel right_accel])
%   In rad/s^2: added to the wheel speeds every step (before the step's motion) until changed.
  check_pair(accel, 'setaccel');
  simrobot.accel = double(accel(:)');
  new = simrobot;
end
