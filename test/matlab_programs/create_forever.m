function create_forever(serPort)
% CREATE_FOREVER  Never returns: drives in a circle, polling the bumpers (killed by the test).
while true
    BumpsWheelDropsSensorsRoomba(serPort);
    SetFwdVelAngVelCreate(serPort, 0.2, 0.5);
    pause(0.05);
end
end
