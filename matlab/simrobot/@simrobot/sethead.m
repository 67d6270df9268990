function new = sethead(simrobot, heading)
% SETHEAD  Not available: the world owns the robot's pose.
%   new = sethead(simrobot, heading) is an error here (the original turned the robot on the spot,
%   through walls and robots). Turn with setvel, e.g. setvel(simrobot, [-0.5 0.5]).
  error('sethead: robot ''%s'': the world owns the heading; turn with setvel', simrobot.name);
end
