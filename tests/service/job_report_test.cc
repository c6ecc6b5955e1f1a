// A job's summary and log line, built from its JobReport (server/convert.h).
#include <string>

#include "gtest/gtest.h"
#include "server/convert.h"

namespace meshsmooth::server {
namespace {

JobReport Finished() {
  JobReport r;
  r.job_id = "5f3a-7";
  r.vertices = 2562;
  r.flow.iterations_run = 12;
  r.flow.stop_reason = StopReason::kTolerance;
  r.flow.effective_step = 0.25;
  r.decode_seconds = 0.0123;
  r.queue_seconds = 0.5;
  r.smooth_seconds = 1.25;
  r.encode_seconds = 0.0625;
  r.total_seconds = 2.0;
  r.before.area = 12.5;
  r.after.area = 12.0;
  r.result_bytes = 4096;
  return r;
}

TEST(JobReportTest, LogLineNamesTheJobItsFlowAndItsTimes) {
  JobParams params;  // the default flow, bilaplacian
  params.flow.iterations = 20;
  JobReport r = Finished();
  EXPECT_EQ(JobLogLine(r, params),
            "meshsmoothd job=5f3a-7 flow=bilaplacian vertices=2562 iterations=12/20 status=OK decode=0.012s "
            "queue=0.500s smooth=1.250s encode=0.062s");
  JobReport failed;
  failed.job_id = "x";
  failed.status = "RESOURCE_EXHAUSTED";
  failed.queue_seconds = 3.0;
  EXPECT_EQ(JobLogLine(failed, params),
            "meshsmoothd job=x flow=bilaplacian vertices=0 iterations=0/20 status=RESOURCE_EXHAUSTED decode=0.000s "
            "queue=3.000s smooth=0.000s encode=0.000s");
  // With the client's address, and a failed job's error, quoted.
  failed.error = "the mesh has 2562 vertices, above this server's limit of 1000 (--max-vertices)";
  EXPECT_EQ(JobLogLine(failed, params, "ipv4:127.0.0.1:4242"),
            "meshsmoothd job=x flow=bilaplacian vertices=0 iterations=0/20 status=RESOURCE_EXHAUSTED decode=0.000s "
            "queue=3.000s smooth=0.000s encode=0.000s peer=ipv4:127.0.0.1:4242 error=\"the mesh has 2562 vertices, "
            "above this server's limit of 1000 (--max-vertices)\"");
  params.flow.iterations = kAutoIterations;
  r.flow.stop_reason = StopReason::kNoiseRemoved;
  EXPECT_EQ(JobLogLine(r, params),
            "meshsmoothd job=5f3a-7 flow=bilaplacian vertices=2562 iterations=12/auto status=OK decode=0.012s "
            "queue=0.500s smooth=1.250s encode=0.062s");
  // A default job logs the flow it chose, not the default flow.
  r.flow.flow = FlowId::kBilateralNormal;
  EXPECT_EQ(JobLogLine(r, params),
            "meshsmoothd job=5f3a-7 flow=bilateral_normal vertices=2562 iterations=12/auto status=OK decode=0.012s "
            "queue=0.500s smooth=1.250s encode=0.062s");
}

TEST(JobReportTest, SummaryCarriesWhatTheJobMeasured) {
  JobParams params;
  params.flow.iterations = 20;
  JobReport r = Finished();
  v1::Summary s = MakeSummary(r, params);
  EXPECT_EQ(s.job_id(), "5f3a-7");
  EXPECT_EQ(s.before().area(), 12.5);
  EXPECT_EQ(s.after().area(), 12.0);
  EXPECT_EQ(s.timings().decode_seconds(), 0.0123);
  EXPECT_EQ(s.timings().queue_seconds(), 0.5);
  EXPECT_EQ(s.timings().smooth_seconds(), 1.25);
  EXPECT_EQ(s.timings().encode_seconds(), 0.0625);
  EXPECT_EQ(s.timings().total_seconds(), 2.0);
  EXPECT_EQ(s.parameters().iterations_run(), 12u);
  EXPECT_EQ(s.parameters().iterations_requested(), 20u);
  EXPECT_EQ(s.parameters().stop_reason(), "tolerance");
  EXPECT_EQ(s.parameters().effective_step(), 0.25);
  EXPECT_EQ(s.result_bytes(), 4096u);
  EXPECT_EQ(s.rms_displacement(), 0.0) << "no displacement measured";
  EXPECT_FALSE(s.has_features()) << "features not asked for";

  r.displacement = Displacement{0.5, 2.0, 3};
  r.features = FeatureSummary{7, 9, 2000, 0.125};
  s = MakeSummary(r, params);
  EXPECT_EQ(s.rms_displacement(), 0.5);
  EXPECT_EQ(s.max_displacement(), 2.0);
  EXPECT_EQ(s.flipped_normals(), 3);
  ASSERT_TRUE(s.has_features());
  EXPECT_EQ(s.features().ridge_vertices(), 7);
  EXPECT_EQ(s.features().ravine_vertices(), 9);
  EXPECT_EQ(s.features().classified_vertices(), 2000);
  EXPECT_EQ(s.features().detect_seconds(), 0.125);
}

}  // namespace
}  // namespace meshsmooth::server
