#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "publishmessages.h"

#include <mosquitto.h>

#include "landmarkjson.h"

namespace landmark {

bool
mqtt_topic_level_ok (const std::string & s, std::string * why)
{
  if (s.empty ()) {
    *why = "it is empty";
    return false;
  }
  if (!g_utf8_validate (s.c_str (), s.size (), nullptr)) {
    *why = "it is not valid UTF-8";
    return false;
  }
  for (char c : s) {
    if (c == '/' || c == '+' || c == '#') {
      *why = std::string ("it contains '") + c + "' (topic separators and "
          "wildcards cannot be part of a name)";
      return false;
    }
  }
  return true;
}

bool
mqtt_topic_expand (const std::string & tmpl, const std::string & robot,
    const std::string & client_id, std::string * out, std::string * why)
{
  std::string o;
  for (size_t i = 0; i < tmpl.size ();) {
    const char ch = tmpl[i];
    if (ch == '{') {
      const size_t end = tmpl.find ('}', i);
      if (end == std::string::npos) {
        *why = "'{' at position " + std::to_string (i) + " is not closed";
        return false;
      }
      const std::string name = tmpl.substr (i + 1, end - i - 1);
      if (name == "robot")
        o += robot;
      else if (name == "client-id")
        o += client_id;
      else {
        *why = "unknown placeholder '{" + name + "}' (known: {robot}, "
            "{client-id})";
        return false;
      }
      i = end + 1;
      continue;
    }
    if (ch == '}') {
      *why = "'}' at position " + std::to_string (i) + " has no '{'";
      return false;
    }
    if (ch == '+' || ch == '#') {
      *why = std::string ("it contains the wildcard '") + ch + "', which "
          "only subscriptions may use";
      return false;
    }
    o += ch;
    i++;
  }
  if (o.empty ()) {
    *why = "it is empty";
    return false;
  }
  if (mosquitto_pub_topic_check2 (o.c_str (), o.size ()) != MOSQ_ERR_SUCCESS
      || mosquitto_validate_utf8 (o.c_str (), (int) o.size ()) !=
      MOSQ_ERR_SUCCESS) {
    *why = "\"" + o + "\" is not a valid MQTT topic";
    return false;
  }
  *out = o;
  return true;
}

/* `{"robot": ROBOT` (the object every message is, unclosed) */
static std::string
robot_object (const std::string & robot)
{
  std::string o = "{\"robot\": ";
  landmark_json::put_string (o, robot.c_str ());
  return o;
}

/* o with `, "wall-time": SECONDS` (since 1970, UTC, now) and then end */
static std::string
with_wall_time (std::string & o, const char *end)
{
  o += ", \"wall-time\": ";
  landmark_json::put_double (o, g_get_real_time () / 1e6);
  return o + end;
}

std::string
publish_status_payload (const std::string & robot,
    const std::string & client_id, const char *status)
{
  std::string o = robot_object (robot);
  o += ", \"client-id\": ";
  landmark_json::put_string (o, client_id.c_str ());
  o += ", \"status\": ";
  landmark_json::put_string (o, status);
  return with_wall_time (o, "}");
}

std::string
publish_frame_head (const std::string & robot, GstBuffer * buf,
    const GstSegment * segment)
{
  std::string o = robot_object (robot);
  if (GST_BUFFER_PTS_IS_VALID (buf) && segment->format == GST_FORMAT_TIME) {
    const guint64 rt = gst_segment_to_running_time (segment,
        GST_FORMAT_TIME, GST_BUFFER_PTS (buf));
    if (GST_CLOCK_TIME_IS_VALID (rt)) {
      o += ", \"running-time\": ";
      landmark_json::put_uint (o, rt);
    }
  }
  return with_wall_time (o, ", ");
}

std::string
publish_frame_payload (const std::string & head, GstBuffer * buf,
    guint64 frame, gint width, gint height,
    std::vector<GstVideoRegionOfInterestMeta *> & rois)
{
  std::string o = head;
  landmark_json::put_frame_fields (o, buf, frame, width, height, rois);
  o += '}';
  return o;
}

std::string
publish_pose_payload (const std::string & head, guint64 frame,
    const GstStructure * pose)
{
  std::string o = head;
  o += "\"frame\": ";
  landmark_json::put_uint (o, frame);
  o += ", \"pose\": ";
  landmark_json::put_structure (o, pose);
  o += '}';
  return o;
}

}  // namespace landmark
