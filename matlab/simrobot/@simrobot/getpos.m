function position = getpos(simrobot)
% GETPOS  The robot's position [x y] in map cells (double).
%   position = getpos(simrobot)
%   The lower left corner of the world (the map's) is [0 0]; x to the right, y up.
  position = simrobot.position;
end
