function new = writemem(simrobot, data)
% WRITEMEM  Store data (any value) in the robot's memory (userdata).
%   new = writemem(simrobot, data); read it back with readmem in a later step.
  simrobot.userdata = data;
  new = simrobot;
end
