classdef CreateRobot < handle
% CREATEROBOT  A simulated iRobot Create, driven through robot_sims' MATLAB bridge.
%
%   serPort = CreateRobot()            connects to the bridge on 127.0.0.1:47800
%   serPort = CreateRobot(port)        ... on another port (robot_sims matlab_bridge --port)
%   serPort = CreateRobot(port, host)  ... on another loopback address
%
%   Pass serPort to the Create toolbox functions exactly as the real robot's serial port:
%   SetFwdVelAngVelCreate(serPort, 0.2, 0), BumpsWheelDropsSensorsRoomba(serPort), travelDist,
%   turnAngle, ReadSonar, LidarSensorCreate, OverheadLocalizationCreate, ... These functions are
%   methods of this class, so MATLAB and Octave call them for a CreateRobot and the real robot's
%   toolbox functions for a serial port: both toolboxes can be on the path at once, and a control
%   program written as function prog(serPort) runs unchanged on either.
%
%   Help on one function: help CreateRobot.travelDist (MATLAB also: help CreateRobot/travelDist).
%   The program ends its session with clear serPort (or by ending Octave/MATLAB); the robot is
%   then stopped. Units are the toolbox's: m, m/s, rad/s; turnAngle takes degrees.
%   pause, tic and toc measure wall time: they match the robot's time when the world runs at
%   real_time_factor 1 (the default).
%
%   Ctrl-C inside a call (travelDist, turnAngle, ...) cancels it: the robot stops and serPort
%   stays usable, the next call answered as if nothing happened. A world that stops answering
%   makes every call an error CreateRobot:bridge within about a second.

  properties (SetAccess = private)
    Port       % the bridge's TCP port
    Host       % the bridge's address (loopback)
    Namespace  % the robot's ROS namespace, as the bridge reported it
  end

  properties (Access = private)
    Socket
    NextId = 0         % the id of the last request sent (one reply per request, matched by id)
    Pending = 0        % the id of the request waiting for its reply (0: none)
    Buffer = ''        % what the bridge sent that is not read yet
    RawRead = []       % Octave: instrument-control's own read/write/bytes-available, skipping
    RawWrite = []      %   the argument checks of read() and get() (a third of a call's time)
    RawAvailable = []
  end

  methods
    function obj = CreateRobot(port, host)
      % CREATEROBOT  Connect to the robot_sims MATLAB bridge: serPort = CreateRobot(port, host).
      if nargin < 1 || isempty(port)
        port = 47800;
      end
      if nargin < 2 || isempty(host)
        host = '127.0.0.1';
      end
      if exist('OCTAVE_VERSION', 'builtin')
        pkg('load', 'instrument-control');
      end
      obj.Port = port;
      obj.Host = host;
      try
        obj.Socket = tcpclient(host, port);
      catch err
        error('CreateRobot:connect', ...
              'cannot reach the robot_sims MATLAB bridge at %s:%d (is robot_sims matlab_bridge running?): %s', ...
              host, port, err.message);
      end
      if exist('OCTAVE_VERSION', 'builtin') && exist('__tcpclient_read__') == 3
        % (through str2func: MATLAB would not parse these names)
        obj.RawRead = str2func('__tcpclient_read__');
        obj.RawWrite = str2func('__tcpclient_write__');
        obj.RawAvailable = str2func('__tcpclient_properties__');
      elseif ~exist('OCTAVE_VERSION', 'builtin')
        obj.Socket.Timeout = 1e6;  % travelDist and turnAngle block until the robot is there
      end
      key = strtrim(getenv('ROBOT_SIMS_BRIDGE_KEY'));
      if ~isempty(key)
        % A bridge started with a key (the studio makes one per run, in this process's
        % environment) serves only connections that send it first: no other local user can.
        send(obj, ['key ', key, char(10)]);
      end
      try
        hello = strsplit(readLine(obj), ' ');
      catch err
        if isempty(key)
          error('CreateRobot:connect', ...
                'the robot_sims MATLAB bridge at %s:%d closed the connection: it may want its key (set ROBOT_SIMS_BRIDGE_KEY)', ...
                host, port);
        end
        rethrow(err);
      end
      if strcmp(hello{1}, 'busy')
        error('CreateRobot:busy', '%s', strjoin(hello(2:end), ' '));
      end
      if numel(hello) < 3 || ~strcmp(hello{1}, 'robot_sims-matlab') || ~strcmp(hello{2}, '2')
        error('CreateRobot:protocol', 'not a robot_sims MATLAB bridge (protocol 2) at %s:%d: %s', ...
              host, port, strjoin(hello, ' '));
      end
      obj.Namespace = strjoin(hello(4:end), ' ');
    end

    function delete(obj)
      % DELETE  End the session: the bridge stops the robot.
      if ~isempty(obj.Socket)
        try
          write(obj.Socket, uint8(['bye', char(10)]));
        catch
        end
        obj.Socket = [];
      end
    end

    function serPort = RoombaInit(serPort, varargin)
      % ROOMBAINIT  Returns serPort: the simulated robot is connected already (by CreateRobot).
      %   serPort = RoombaInit(serPort) lets a program that calls RoombaInit run unchanged.
    end

    function SetFwdVelAngVelCreate(serPort, FwdVel, AngVel)
      % SETFWDVELANGVELCREATE  Drive at a forward and an angular velocity.
      %   SetFwdVelAngVelCreate(serPort, FwdVel, AngVel): FwdVel in m/s (forward > 0), AngVel in
      %   rad/s (counter-clockwise > 0). Each wheel is limited to +-0.5 m/s. Returns at once; the
      %   robot keeps this velocity until the next command.
      call(serPort, 'SetFwdVelAngVelCreate', FwdVel, AngVel);
    end

    function SetFwdVelRadiusRoomba(serPort, FwdVel, Radius)
      % SETFWDVELRADIUSROOMBA  Drive at FwdVel (m/s) on a circle of Radius (m, left > 0).
      %   SetFwdVelRadiusRoomba(serPort, FwdVel, Radius): Radius inf drives straight; other radii
      %   are kept within 0.001-2 m in magnitude, as on the robot.
      call(serPort, 'SetFwdVelRadiusRoomba', FwdVel, Radius);
    end

    function SetDriveWheelsCreate(serPort, rightWheelVel, leftWheelVel)
      % SETDRIVEWHEELSCREATE  Set each wheel's velocity (m/s, +-0.5 m/s at most).
      %   SetDriveWheelsCreate(serPort, rightWheelVel, leftWheelVel)
      call(serPort, 'SetDriveWheelsCreate', rightWheelVel, leftWheelVel);
    end

    function travelDist(serPort, roombaSpeed, distance)
      % TRAVELDIST  Drive a distance in a straight line, then stop; returns when there.
      %   travelDist(serPort, roombaSpeed, distance): roombaSpeed in m/s (its magnitude, kept in
      %   0.025-0.5), distance in m (negative = backwards), measured by odometry. A wall in the way
      %   stops the robot, and then travelDist waits on, as on the real robot. Ctrl-C stops it.
      call(serPort, 'travelDist', roombaSpeed, distance);
    end

    function TravelDistCreate(serPort, speed, distance)
      % TRAVELDISTCREATE  travelDist under the name the 2023 toolbox added: the same call.
      %   TravelDistCreate(serPort, speed, distance): speed in m/s (0.025-0.5), distance in m.
      call(serPort, 'TravelDistCreate', speed, distance);
    end

    function turnAngle(serPort, roombaSpeed, turnAngle)
      % TURNANGLE  Turn in place by an angle the short way round, then stop; returns when turned.
      %   turnAngle(serPort, roombaSpeed, turnAngle): roombaSpeed in rad/s (its magnitude, kept in
      %   0.025-0.2), turnAngle in degrees, measured by odometry. As the toolbox, the angle is
      %   wrapped into [-180 180]: 270 turns 90 degrees clockwise, 360 does not turn; positive
      %   turns counter-clockwise. Ctrl-C stops it.
      call(serPort, 'turnAngle', roombaSpeed, turnAngle);
    end

    function TurnCreate(serPort, speed, angle)
      % TURNCREATE  turnAngle under the name the 2023 toolbox added: the same call.
      %   TurnCreate(serPort, speed, angle): speed in rad/s (0-0.2), angle in degrees (+-360).
      call(serPort, 'TurnCreate', speed, angle);
    end

    function BeepRoomba(serPort)
      % BEEPROOMBA  Beep (here: this computer's beep).
      call(serPort, 'BeepRoomba');
      beep;
    end

    function BeepCreate(serPort)
      % BEEPCREATE  BeepRoomba under the name the 2023 toolbox added: the same call.
      call(serPort, 'BeepCreate');
      beep;
    end

    function DemoCmdsCreate(serPort, DemoNum)
      % DEMOCMDSCREATE  The robot's built-in demos: as in the original simulator, none is run.
      %   DemoCmdsCreate(serPort, DemoNum): DemoNum -1 (abort) to 9; anything else is an error.
      call(serPort, 'DemoCmdsCreate', DemoNum);
      fprintf('Demo number %.0f selected.\n', DemoNum)
      disp('WARNING:Currently no simulator demo functionality.')
    end

    function SetLEDsRoomba(serPort, LED, Color, Intensity)
      % SETLEDSROOMBA  Set the Advance/Play LEDs: checked like the robot's, nothing to light here.
      %   SetLEDsRoomba(serPort, LED, Color, Intensity): LED 0 none, 1 Advance, 2 Play, 3 both;
      %   Color 0 (green) to 100 (red); Intensity 1 to 100.
      call(serPort, 'SetLEDsRoomba', LED, Color, Intensity);
    end

    function [BumpRight, BumpLeft, WheDropRight, WheDropLeft, WheDropCaster, BumpFront] = BumpsWheelDropsSensorsRoomba(serPort)
      % BUMPSWHEELDROPSSENSORSROOMBA  The bumpers and wheel drops (1 = pressed/dropped, else 0).
      %   [BumpRight, BumpLeft, WheDropRight, WheDropLeft, WheDropCaster, BumpFront] =
      %   BumpsWheelDropsSensorsRoomba(serPort). Both bumpers pressed read as BumpFront only. The
      %   simulated floor has no cliffs: the wheel drops read 0.
      o = call(serPort, 'BumpsWheelDropsSensorsRoomba');
      [BumpRight, BumpLeft, WheDropRight, WheDropLeft, WheDropCaster, BumpFront] = o{:};
    end

    function Wall = WallSensorReadRoomba(serPort)
      % WALLSENSORREADROOMBA  The IR wall sensor on the front right: 1 when a wall is close, else 0.
      o = call(serPort, 'WallSensorReadRoomba');
      Wall = o{1};
    end

    function VirtWall = VirtualWallSensorCreate(serPort)
      % VIRTUALWALLSENSORCREATE  1 when the robot is inside a virtual wall's field or halo, else 0.
      o = call(serPort, 'VirtualWallSensorCreate');
      VirtWall = o{1};
    end

    function Strength = CliffLeftSignalStrengthRoomba(serPort)
      % CLIFFLEFTSIGNALSTRENGTHROOMBA  The left cliff sensor's signal strength (%).
      %   About 21.5 on the floor and 1.5 over a line of the map.
      o = call(serPort, 'CliffLeftSignalStrengthRoomba');
      Strength = o{1};
    end

    function Cliff = CliffLeftSensorRoomba(serPort)
      % CLIFFLEFTSENSORROOMBA  The left cliff sensor: always 0 (the simulated floor has no cliffs).
      o = call(serPort, 'CliffLeftSensorRoomba');
      Cliff = o{1};
    end

    function Strength = CliffFrontLeftSignalStrengthRoomba(serPort)
      % CLIFFFRONTLEFTSIGNALSTRENGTHROOMBA  The front left cliff sensor's signal strength (%).
      %   About 21.5 on the floor and 1.5 over a line of the map.
      o = call(serPort, 'CliffFrontLeftSignalStrengthRoomba');
      Strength = o{1};
    end

    function Cliff = CliffFrontLeftSensorRoomba(serPort)
      % CLIFFFRONTLEFTSENSORROOMBA  The front left cliff sensor: always 0 (the simulated floor has no cliffs).
      o = call(serPort, 'CliffFrontLeftSensorRoomba');
      Cliff = o{1};
    end

    function Strength = CliffFrontRightSignalStrengthRoomba(serPort)
      % CLIFFFRONTRIGHTSIGNALSTRENGTHROOMBA  The front right cliff sensor's signal strength (%).
      %   About 21.5 on the floor and 1.5 over a line of the map.
      o = call(serPort, 'CliffFrontRightSignalStrengthRoomba');
      Strength = o{1};
    end

    function Cliff = CliffFrontRightSensorRoomba(serPort)
      % CLIFFFRONTRIGHTSENSORROOMBA  The front right cliff sensor: always 0 (the simulated floor has no cliffs).
      o = call(serPort, 'CliffFrontRightSensorRoomba');
      Cliff = o{1};
    end

    function Strength = CliffRightSignalStrengthRoomba(serPort)
      % CLIFFRIGHTSIGNALSTRENGTHROOMBA  The right cliff sensor's signal strength (%).
      %   About 21.5 on the floor and 1.5 over a line of the map.
      o = call(serPort, 'CliffRightSignalStrengthRoomba');
      Strength = o{1};
    end

    function Cliff = CliffRightSensorRoomba(serPort)
      % CLIFFRIGHTSENSORROOMBA  The right cliff sensor: always 0 (the simulated floor has no cliffs).
      o = call(serPort, 'CliffRightSensorRoomba');
      Cliff = o{1};
    end

    function distance = ReadSonar(serPort, sonarNum)
      % READSONAR  The distance (m) a sonar measures from the robot's edge.
      %   distance = ReadSonar(serPort, sonarNum): sonarNum 1 right, 2 front (the default), 3 left,
      %   4 back. As the toolbox: [] when nothing is in range, i.e. no echo, 3 m or further, or
      %   0.17 m or closer.
      if nargin < 2
        o = call(serPort, 'ReadSonar');
      else
        o = call(serPort, 'ReadSonar', sonarNum);
      end
      distance = o{1};
    end

    function distances = ReadSonarMultiple(serPort, varargin)
      % READSONARMULTIPLE  One sonar (m), as the toolbox: ReadSonarMultiple(serPort, sonarNum).
      %   distance = ReadSonarMultiple(serPort, sonarNum): sonarNum 1 right, 2 front, 3 left,
      %   4 back; [] when nothing is in range (closer than 0.17 m, further than 3 m).
      %   Beyond the toolbox: ReadSonarMultiple(serPort) reads all four as [right front left
      %   back], ReadSonarMultiple(serPort, 2, 3) those named, in that order; NaN where nothing
      %   is in range.
      o = call(serPort, 'ReadSonarMultiple', varargin{:});
      if numel(varargin) == 1
        distances = o{1};
      else
        distances = reshape(o{1}, 1, []);
      end
    end

    function ranges = LidarSensorCreate(serPort)
      % LIDARSENSORCREATE  The LIDAR's 681 ranges (m), a row from -120 deg (right) to +120 deg (left).
      %   ranges = LidarSensorCreate(serPort): 0.02-4 m; a ray with nothing in range reads 4.
      o = call(serPort, 'LidarSensorCreate');
      ranges = reshape(o{1}, 1, []);
    end

    function [angle, dist, color] = CameraSensorCreate(serPort)
      % CAMERASENSORCREATE  The beacons the front camera sees.
      %   [angle, dist, color] = CameraSensorCreate(serPort): per beacon (one row each) the angle
      %   (rad, left > 0), the distance (m) and the [r g b] colour; empty when it sees none.
      o = call(serPort, 'CameraSensorCreate');
      angle = reshape(o{1}, [], 1);
      dist = reshape(o{2}, [], 1);
      color = reshape(o{3}, [], 3);
    end

    function [X, Y, Z, ROT, Ntag] = ReadBeacon(serPort)
      % READBEACON  The AR-tag beacons the camera sees, in the camera's frame.
      %   [X, Y, Z, ROT, Ntag] = ReadBeacon(serPort): column vectors, a row per beacon: X right,
      %   Y down (0: tags are level with the camera), Z ahead (m), ROT the tag's rotation (0:
      %   upright), Ntag the tag's number (the map file's id; NaN for an id that is not a number).
      %   Empty when the camera sees none.
      o = call(serPort, 'ReadBeacon');
      [X, Y, Z, ROT, Ntag] = deal(reshape(o{1}, [], 1), reshape(o{2}, [], 1), reshape(o{3}, [], 1), ...
                                  reshape(o{4}, [], 1), reshape(o{5}, [], 1));
    end

    function depth_array = RealSenseDist(serPort)
      % REALSENSEDIST  The RealSense depth camera: a column of 10, [dt; 9 depths] (s; m).
      %   depth_array = RealSenseDist(serPort): dt is how old the reading is (s of the robot's
      %   time); then the depth (distance along the heading, from the robot's centre) seen on 9
      %   rays from 27 deg left to 27 deg right, left-most first: 0 when closer than 0.175 m, 10
      %   when nothing is in range. The depths come from the LIDAR's rays at those bearings (it
      %   sees 4 m from the front edge: beyond that, 10).
      o = call(serPort, 'RealSenseDist');
      depth_array = reshape(o{1}, [], 1);
    end

    function tags = RealSenseTag(serPort)
      % REALSENSETAG  The AprilTags (the map's beacons) the camera sees: a row [dt id x y rot] each.
      %   tags = RealSenseTag(serPort): dt how old the reading is (s), id the tag's number (NaN
      %   for a map id that is not a number), x ahead of and y left of the camera (m), rot the
      %   tag's rotation (0: upright). Empty when the camera sees none.
      o = call(serPort, 'RealSenseTag');
      if isempty(o{1})
        tags = zeros(0, 5);
      else
        tags = reshape(o{1}, [], 5);
      end
    end

    function [x, y, theta] = OverheadLocalizationCreate(serPort)
      % OVERHEADLOCALIZATIONCREATE  The robot's exact pose from the overhead cameras.
      %   [x, y, theta] = OverheadLocalizationCreate(serPort): x, y in m in the map's frame, theta in
      %   rad (counter-clockwise from the x axis).
      o = call(serPort, 'OverheadLocalizationCreate');
      [x, y, theta] = o{:};
    end

    function distance = DistanceSensorRoomba(serPort)
      % DISTANCESENSORROOMBA  The distance (m) driven since the last call (odometry; backwards < 0).
      %   The first call of a program counts from its connection.
      o = call(serPort, 'DistanceSensorRoomba');
      distance = o{1};
    end

    function angle = AngleSensorRoomba(serPort)
      % ANGLESENSORROOMBA  The angle (rad, counter-clockwise > 0) turned since the last call (odometry).
      o = call(serPort, 'AngleSensorRoomba');
      angle = o{1};
    end

    function [ButtonAdv, ButtonPlay] = ButtonsSensorRoomba(serPort)
      % BUTTONSSENSORROOMBA  The Advance and Play buttons: 1 when pressed, else 0.
      o = call(serPort, 'ButtonsSensorRoomba');
      [ButtonAdv, ButtonPlay] = o{:};
    end

    function [Charge, Capacity, Percent] = BatteryChargeReaderRoomba(serPort)
      % BATTERYCHARGEREADERROOMBA  The battery's charge and capacity (mAh) and the percent charged.
      o = call(serPort, 'BatteryChargeReaderRoomba');
      [Charge, Capacity, Percent] = o{:};
    end

    function Voltage = BatteryVoltageRoomba(serPort)
      % BATTERYVOLTAGEROOMBA  The battery's voltage (V).
      o = call(serPort, 'BatteryVoltageRoomba');
      Voltage = o{1};
    end

    function Current = CurrentTesterRoomba(serPort)
      % CURRENTTESTERROOMBA  The battery's current (A, discharging < 0).
      o = call(serPort, 'CurrentTesterRoomba');
      Current = o{1};
    end

    function [BumpRight, BumpLeft, BumpFront, Wall, virtWall, CliffLft, CliffRgt, CliffFrntLft, CliffFrntRgt, LeftCurrOver, RightCurrOver, DirtL, DirtR, ButtonPlay, ButtonAdv, Dist, Angle, Volts, Current, Temp, Charge, Capacity, pCharge] = AllSensorsReadRoomba(serPort)
      % ALLSENSORSREADROOMBA  Every basic sensor at once, in this order:
      %   [BumpRight, BumpLeft, BumpFront, Wall, virtWall, CliffLft, CliffRgt, CliffFrntLft,
      %    CliffFrntRgt, LeftCurrOver, RightCurrOver, DirtL, DirtR, ButtonPlay, ButtonAdv, Dist,
      %    Angle, Volts, Current, Temp, Charge, Capacity, pCharge] = AllSensorsReadRoomba(serPort)
      %   Dist (m) and Angle (rad) count since their last reading, as DistanceSensorRoomba and
      %   AngleSensorRoomba; cliffs, motor over-currents and dirt read 0.
      o = call(serPort, 'AllSensorsReadRoomba');
      [BumpRight, BumpLeft, BumpFront, Wall, virtWall, CliffLft, CliffRgt, CliffFrntLft, CliffFrntRgt, LeftCurrOver, RightCurrOver, DirtL, DirtR, ButtonPlay, ButtonAdv, Dist, Angle, Volts, Current, Temp, Charge, Capacity, pCharge] = o{:};
    end
  end

  methods (Access = private)
    function out = call(obj, name, varargin)
      % One request to the bridge, one reply: the outputs as a cell array, or an error.
      if isempty(obj.Socket)
        error('CreateRobot:closed', '%s: this CreateRobot is disconnected; connect again with CreateRobot', name);
      end
      for k = 1:numel(varargin)
        value = varargin{k};
        if ~(isnumeric(value) || islogical(value)) || ~isscalar(value)
          error('CreateRobot:invalidInput', '%s: argument %d must be a number', name, k + 1);
        end
        varargin{k} = double(value);
      end
      id = obj.NextId + 1;
      obj.NextId = id;
      tag = sprintf('@%d ', id);
      obj.Pending = id;
      % Ctrl-C (or an error) before the reply came: tell the bridge, which ends the call and
      % stops the robot; the reply it still sends has this id, and the next call skips it.
      guard = onCleanup(@() abandon(obj, id));
      send(obj, [tag, name, sprintf(' %.17g', varargin{:}), char(10)]);
      reply = readLine(obj);
      while ~strncmp(reply, tag, numel(tag))
        reply = readLine(obj);  % the reply to a call interrupted earlier
      end
      obj.Pending = 0;
      reply = reply(numel(tag) + 1:end);
      if strncmp(reply, 'error ', 6)
        error('CreateRobot:bridge', '%s: %s', name, reply(7:end));
      elseif ~strncmp(reply, 'ok', 2)
        error('CreateRobot:protocol', '%s: unexpected reply from the bridge: %s', name, reply);
      end
      edges = [find(reply == 9), numel(reply) + 1];  % the outputs, tab-separated (strsplit is slow)
      out = cell(1, numel(edges) - 1);
      for k = 1:numel(out)
        out{k} = jsondecode(reply(edges(k) + 1:edges(k + 1) - 1));
      end
    end

    function abandon(obj, id)
      % The call with this id ended without its reply (interrupted): cancel it at the bridge.
      if obj.Pending == id && ~isempty(obj.Socket)
        obj.Pending = 0;
        try
          send(obj, sprintf('@%d cancel\n', id));
        catch
        end
      end
    end

    function send(obj, line)
      if isempty(obj.RawWrite)
        write(obj.Socket, uint8(line));
      else
        obj.RawWrite(obj.Socket, uint8(line));
      end
    end

    function line = readLine(obj)
      % The bridge's next line, without its newline. Octave: reads of at most 20 ms each, so that
      % Ctrl-C and signals are handled at once, not when the bridge answers.
      eol = find(obj.Buffer == 10, 1);
      while isempty(eol)
        try
          if isempty(obj.RawRead)
            data = read(obj.Socket, max(obj.Socket.NumBytesAvailable, 1));
            if isempty(data)
              error('CreateRobot:closed', 'no data');
            end
          else
            data = obj.RawRead(obj.Socket, max(obj.RawAvailable(obj.Socket, 'NumBytesAvailable'), 1), 20);
          end
        catch err
          obj.Socket = [];
          obj.Pending = 0;
          error('CreateRobot:closed', 'the robot_sims MATLAB bridge closed the connection (%s)', err.message);
        end
        obj.Buffer = [obj.Buffer, char(reshape(data, 1, []))];
        eol = find(obj.Buffer == 10, 1);
      end
      line = obj.Buffer(1:eol - 1);
      obj.Buffer = obj.Buffer(eol + 1:end);
    end
  end
end
