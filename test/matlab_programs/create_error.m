function create_error(serPort)
% CREATE_ERROR  Drives, then asks for a sonar the robot does not have: the bridge's error.
SetFwdVelAngVelCreate(serPort, 0.2, 0);
pause(0.5);
d = ReadSonar(serPort, 9);
end
