function r = simrobot_refresh(r, position, heading, velocity, accel, power, crashed, values, nums)
% SIMROBOT_REFRESH  (system) The world's state of this step into the robot, before its algorithm
%   runs: position [x y] (cells), heading (degrees), velocity, accel, power, crashed, and every
%   sensor's reading (values/nums: its slice of the step's readings). Memory is kept.
  r.position = position;
  r.heading = heading;
  r.velocity = velocity;
  r.accel = accel;
  r.power = power;
  r.crashed = crashed;
  for k = 1:numel(r.sensors)
    rays = r.sensors(k).first:r.sensors(k).last;
    r.sensors(k).distance = values(rays);
    r.sensors(k).num = nums(rays);
  end
end
