function number = getnum(simrobot)
% GETNUM  The robot's ID number (double, an integer): 2 for the first robot, then 3, 4, ...
%   number = getnum(simrobot). Robots show this number in the matrix and in readings' num.
  number = simrobot.number;
end
