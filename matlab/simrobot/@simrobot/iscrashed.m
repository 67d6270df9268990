function flag = iscrashed(simrobot)
% ISCRASHED  The crash flag: 1 if the robot has crashed (it then stops), otherwise 0.
%   flag = iscrashed(simrobot)
  flag = simrobot.crashed;
end
