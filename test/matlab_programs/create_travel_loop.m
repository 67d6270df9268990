function create_travel_loop(serPort)
% CREATE_TRAVEL_LOOP  The manual's structure: a tic/toc loop of toolbox calls, here travelDist
%   1 m, the bumpers, turnAngle 90 degrees, for a minute (Ctrl-C'd inside its first travelDist).
tic
while toc < 60
    travelDist(serPort, 0.1, 1);
    BumpsWheelDropsSensorsRoomba(serPort);
    turnAngle(serPort, 0.2, 90);
end
end
