function [data, num] = readlaser(simrobot, sensor_name, matrix)
% READLASER  Read a laser scanner of the robot.
%   [data, num] = readlaser(simrobot, sensor_name, matrix)
%   data: 1-by-rays vector of distances (map cells) to the obstacle each ray meets, read
%   counter-clockwise: the first is the rightmost ray (looking from behind the sensor);
%   999999 for a ray that meets nothing in range.
%   num: 1-by-rays obstacle numbers (1 wall, a robot's ID number, 0 nothing; may be omitted).
%   sensor_name: the sensor's name; when several sensors share it, the first one is read.
%   matrix: the world's matrix (accepted as the original's; the reading is the world's).
  k = sensor_lookup(simrobot, sensor_name, 'readlaser');
  sensor = simrobot.sensors(k);
  if ~strcmp(sensor.type, 'laser')
    error('readlaser: sensor ''%s'' of robot ''%s'' is ultrasonic: read it with readusonic', ...
          sensor_name, simrobot.name);
  end
  data = sensor.distance;
  num = sensor.num;
end
