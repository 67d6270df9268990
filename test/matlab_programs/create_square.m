function create_square(serPort)
% CREATE_SQUARE  Drive a 0.25 m square counter-clockwise with travelDist and turnAngle.
%   Its Python twin is create_square.py.
for side = 1:4
    travelDist(serPort, 0.25, 0.25);
    turnAngle(serPort, 0.2, 90);
end
end
