function new = clearcf(simrobot)
% CLEARCF  Clear the robot's crash flag: it may move again from where it stopped.
%   new = clearcf(simrobot)
  simrobot.crashed = 0;
  new = simrobot;
end
