function new = setvel(simrobot, vel)
% SETVEL  Set the angular velocities of the left and right wheel.
%   new = setvel(simrobot, [left_vel right_vel])
%   Wheel speeds in rad/s (rad per step at the original's 1 s step); they hold until changed.
%   [0.5 0.5] drives straight on at 0.5 cell/s with the original's wheels (radius 1 cell),
%   [0 0.5] turns left. Return the new robot from the algorithm (new = simrobot) or the change
%   is lost.
  check_pair(vel, 'setvel');
  simrobot.velocity = double(vel(:)');
  new = simrobot;
end
