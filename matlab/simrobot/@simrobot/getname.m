function name = getname(simrobot)
% GETNAME  The robot's name (string), as in the world file.
%   name = getname(simrobot)
  name = simrobot.name;
end
