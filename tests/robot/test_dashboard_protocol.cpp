// Dashboard server protocol: the documented command lines and golden replies of a UR controller (PolyScope 5
// dashboard server manual), refusals and unexpected replies.
#include <gtest/gtest.h>

#include "mrsns/core/error.h"
#include "mrsns/robot/dashboard_protocol.h"

using namespace mrsns::robot;
using namespace mrsns::robot::dashboard;

TEST(DashboardProtocol, CommandLines) {
  EXPECT_EQ(commandLine(Command::PowerOn), "power on");
  EXPECT_EQ(commandLine(Command::PowerOff), "power off");
  EXPECT_EQ(commandLine(Command::BrakeRelease), "brake release");
  EXPECT_EQ(commandLine(Command::Play), "play");
  EXPECT_EQ(commandLine(Command::Stop), "stop");
  EXPECT_EQ(commandLine(Command::Pause), "pause");
  EXPECT_EQ(commandLine(Command::RobotMode), "robotmode");
  EXPECT_EQ(commandLine(Command::SafetyMode), "safetymode");
  EXPECT_EQ(commandLine(Command::SafetyStatus), "safetystatus");
  EXPECT_EQ(commandLine(Command::UnlockProtectiveStop), "unlock protective stop");
  EXPECT_EQ(commandLine(Command::CloseSafetyPopup), "close safety popup");
  EXPECT_EQ(commandLine(Command::IsInRemoteControl), "is in remote control");
  EXPECT_EQ(commandLine(Command::GetRobotModel), "get robot model");
  EXPECT_EQ(commandLine(Command::GetSerialNumber), "get serial number");
  EXPECT_EQ(commandLine(Command::ProgramState), "programState");
  EXPECT_EQ(commandLine(Command::GetLoadedProgram), "get loaded program");
  EXPECT_EQ(parseCommand("is in remote control\r\n"), Command::IsInRemoteControl);
  // Four numbers, as PolyScope sends them ("URSoftware 5.8.0.10253 (Jun 19 2020)"): ur_rtde parses them all.
  EXPECT_EQ(polyscopeVersionReply(5, 8, 0, 10253), "URSoftware 5.8.0.10253 (MR-SNS UR simulator)");
  EXPECT_TRUE(interpretReply(Command::PolyscopeVersion, successReply(Command::PolyscopeVersion)).accepted);
  EXPECT_EQ(remoteControlReply(true), "true");
  EXPECT_EQ(programStateReply(false), "STOPPED <unnamed>");
  EXPECT_EQ(parseCommand("unlock protective stop\r\n"), Command::UnlockProtectiveStop);
  EXPECT_EQ(parseCommand("  robotmode \n"), Command::RobotMode);
  EXPECT_FALSE(parseCommand("fly"));
  EXPECT_EQ(notUnderstoodReply("fly\n"), "could not understand: 'fly'");
}

TEST(DashboardProtocol, GoldenRepliesAreAccepted) {
  struct Case {
    Command command;
    const char* reply;
  };
  for (const auto& c : {Case{Command::PowerOn, "Powering on\n"}, Case{Command::PowerOff, "Powering off\n"},
                        Case{Command::BrakeRelease, "Brake releasing\n"}, Case{Command::Play, "Starting program\n"},
                        Case{Command::Stop, "Stopped\n"}, Case{Command::Pause, "Pausing program\n"},
                        Case{Command::UnlockProtectiveStop, "Protective stop releasing\n"},
                        Case{Command::CloseSafetyPopup, "closing safety popup\n"}}) {
    const auto r = interpretReply(c.command, c.reply);
    EXPECT_TRUE(r.accepted) << c.reply;
    EXPECT_EQ(r.reply + "\n", c.reply);
    EXPECT_EQ(successReply(c.command) + "\n", c.reply);
  }
}

TEST(DashboardProtocol, RefusalsAreNotErrors) {
  EXPECT_FALSE(interpretReply(Command::Play, "Failed to execute: play").accepted);
  EXPECT_FALSE(interpretReply(Command::UnlockProtectiveStop, unlockTooEarlyReply()).accepted);
  EXPECT_FALSE(interpretReply(Command::Stop, failureReply(Command::Stop)).accepted);
}

TEST(DashboardProtocol, UnexpectedRepliesThrowFormatError) {
  // The greeting instead of a reply, a reply to another command, an empty line, binary garbage.
  EXPECT_THROW((void)interpretReply(Command::PowerOn, "Connected: Universal Robots Dashboard Server"),
               mrsns::FormatError);
  EXPECT_THROW((void)interpretReply(Command::PowerOn, "Powering off"), mrsns::FormatError);
  EXPECT_THROW((void)interpretReply(Command::Play, ""), mrsns::FormatError);
  EXPECT_THROW((void)interpretReply(Command::Play, std::string("\x00\x05\x56", 3)), mrsns::FormatError);
  EXPECT_THROW((void)interpretReply(Command::RobotMode, "Robotmode: RUNNING"), mrsns::InvalidArgumentError);
  try {
    (void)interpretReply(Command::BrakeRelease, "could not understand: 'brake release'");
    FAIL();
  } catch (const mrsns::FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("brake release"), std::string::npos) << e.what();
  }
}

TEST(DashboardProtocol, ModeQueries) {
  EXPECT_EQ(parseRobotModeReply("Robotmode: RUNNING\n"), UrRobotMode::Running);
  EXPECT_EQ(parseRobotModeReply("Robotmode: POWER_OFF"), UrRobotMode::PowerOff);
  EXPECT_EQ(parseRobotModeReply("Robotmode: NO_CONTROLLER"), UrRobotMode::NoController);
  EXPECT_EQ(parseSafetyModeReply("Safetymode: NORMAL"), UrSafetyMode::Normal);
  EXPECT_EQ(parseSafetyModeReply("Safetystatus: PROTECTIVE_STOP\n"), UrSafetyMode::ProtectiveStop);
  EXPECT_EQ(parseSafetyModeReply("Safetystatus: SYSTEM_THREE_POSITION_ENABLING_STOP"),
            UrSafetyMode::SystemThreePositionEnablingStop);
  EXPECT_TRUE(parseRunningReply("Program running: true"));
  EXPECT_FALSE(parseRunningReply("Program running: false\r\n"));
  EXPECT_THROW((void)parseRobotModeReply("Robotmode: FLYING"), mrsns::FormatError);
  EXPECT_THROW((void)parseRobotModeReply("Safetymode: NORMAL"), mrsns::FormatError);
  EXPECT_THROW((void)parseSafetyModeReply("Safetymode:"), mrsns::FormatError);
  EXPECT_THROW((void)parseRunningReply("Program running: maybe"), mrsns::FormatError);
  for (int i = -1; i <= 8; ++i) {
    const auto m = urRobotModeFromInt(i);
    ASSERT_TRUE(m);
    EXPECT_EQ(parseRobotModeReply(robotModeReply(*m)), *m);
  }
  for (int i = 1; i <= 13; ++i) {
    const auto m = urSafetyModeFromInt(i);
    ASSERT_TRUE(m);
    EXPECT_EQ(parseSafetyModeReply(safetyModeReply(*m, i % 2 == 0)), *m);
  }
  EXPECT_FALSE(urRobotModeFromInt(9));
  EXPECT_FALSE(urSafetyModeFromInt(0));
}

TEST(DashboardProtocol, ModeMappingOntoTheArmInterface) {
  EXPECT_EQ(toSafetyMode(UrSafetyMode::ProtectiveStop), SafetyMode::ProtectiveStop);
  EXPECT_EQ(toSafetyMode(UrSafetyMode::SafeguardStop), SafetyMode::ProtectiveStop);
  EXPECT_EQ(toSafetyMode(UrSafetyMode::RobotEmergencyStop), SafetyMode::EmergencyStop);
  EXPECT_EQ(toSafetyMode(UrSafetyMode::SystemEmergencyStop), SafetyMode::EmergencyStop);
  EXPECT_EQ(toSafetyMode(UrSafetyMode::Fault), SafetyMode::Fault);
  EXPECT_EQ(toRobotMode(UrRobotMode::Running), RobotMode::Running);
  EXPECT_EQ(toRobotMode(UrRobotMode::PowerOff), RobotMode::PowerOff);
  for (auto s : {SafetyMode::Normal, SafetyMode::Reduced, SafetyMode::ProtectiveStop, SafetyMode::EmergencyStop,
                 SafetyMode::Violation, SafetyMode::Fault}) {
    EXPECT_EQ(toSafetyMode(toUrSafetyMode(s)), s);
  }
  for (auto m : {RobotMode::Disconnected, RobotMode::PowerOff, RobotMode::Idle, RobotMode::Running}) {
    EXPECT_EQ(toRobotMode(toUrRobotMode(m)), m);
  }
}
