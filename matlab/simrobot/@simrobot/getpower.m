function power = getpower(simrobot)
% GETPOWER  The robot's power switch: 1 (on, it moves) or 0 (off, it keeps its place).
%   power = getpower(simrobot)
  power = simrobot.power;
end
