function [distance, num] = readusonic(simrobot, sensor_name, matrix)
% READUSONIC  Read an ultrasonic sensor of the robot.
%   [distance, num] = readusonic(simrobot, sensor_name, matrix)
%   distance: distance to the nearest obstacle in the sensor's beam, in map cells (1 cell = 1 cm
%   in the original's worlds), measured from the sensor; 999999 when nothing is in range.
%   num: the detected obstacle's number: 1 for a wall, the robot's ID number (2, 3, ...) for a
%   robot, 0 when nothing is in range (it may be omitted).
%   sensor_name: the sensor's name; when several sensors share it, the first one is read.
%   matrix: the world's matrix (accepted as the original's; the reading is the world's).
%   A name no sensor has is an error (the original read its last sensor silently).
  k = sensor_lookup(simrobot, sensor_name, 'readusonic');
  sensor = simrobot.sensors(k);
  if ~strcmp(sensor.type, 'ultrasonic')
    error('readusonic: sensor ''%s'' of robot ''%s'' is a laser: read it with readlaser', ...
          sensor_name, simrobot.name);
  end
  distance = sensor.distance;
  num = sensor.num;
end
