function heading = gethead(simrobot)
% GETHEAD  The robot's heading in degrees, 0 = facing east, counter-clockwise, in [0 360).
%   heading = gethead(simrobot)
  heading = simrobot.heading;
end
